//! Any bytes, read as UTF-8 (lossy), must make `Record::parse` return a
//! record or an error, and whatever it reads must align, warn and drop its
//! outliers without a panic.
#![no_main]

use hbis::data::{record_warnings, Record};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(rec) = Record::parse(&text, 0) else {
        return;
    };
    let _ = rec.without_outliers();
    for t0 in [None, rec.t().first().copied()] {
        if let Ok(aligned) = rec.aligned(t0) {
            let _ = record_warnings(&rec, &aligned);
        }
    }
});
