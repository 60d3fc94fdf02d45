//! Any bytes, read as UTF-8 (lossy), must make `GroundMotion::parse_columns`
//! return a motion or an error in every unit; whatever it reads must give a
//! duration, a PGA and a scaled copy without a panic.
#![no_main]

use hbis::data::ground_motion::GroundMotion;
use hbis::data::AccelUnits;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    for u in AccelUnits::ALL {
        if let Ok(m) = GroundMotion::parse_columns(&text, u) {
            let _ = m.duration();
            let _ = m.pga();
            let _ = m.scaled(0.5);
        }
    }
});
