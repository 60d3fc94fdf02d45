//! Any bytes, read as UTF-8 (lossy), must make `GroundMotion::parse_at2`
//! return a motion or an error, with the header's unit and with each unit
//! given, whatever NPTS and DT the header claims; whatever it reads must
//! give a duration, a PGA and a scaled copy without a panic.
#![no_main]

use hbis::data::ground_motion::GroundMotion;
use hbis::data::AccelUnits;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let units = std::iter::once(None).chain(AccelUnits::ALL.into_iter().map(Some));
    for u in units {
        if let Ok(m) = GroundMotion::parse_at2(&text, u) {
            let _ = m.duration();
            let _ = m.pga();
            let _ = m.scaled(2.0);
        }
    }
});
