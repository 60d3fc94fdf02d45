//! Any bytes, read as UTF-8 (lossy), must make the strict JSON reader and
//! `Params::map_from_json` return a value or an error. A parameter map it
//! reads is put on the Table 8.1 values of a fixed model and turned into
//! its `theta`, which must be accepted or refused without a panic.
#![no_main]

use hbis::data::strict_json;
use hbis::model::{Params, Registry};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = strict_json::parse(&text);
    let Ok(map) = Params::map_from_json(&text) else {
        return;
    };
    let Some(mut p) = Params::table_8_1(5) else {
        return;
    };
    for (name, v) in &map {
        p.set(*name, *v);
    }
    let registry = Registry::builtin();
    if let Ok(model) = registry.parse("trilinear+lcfm+viscous") {
        let _ = model.theta_from_params(&p, &[]);
    }
});
