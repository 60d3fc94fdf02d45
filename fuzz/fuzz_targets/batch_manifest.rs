//! Any bytes, read as UTF-8 (lossy), must make `Study::parse` (the `hbis
//! batch` manifest) return a study or an error. A study it reads must list
//! its items, their folders, `hbis fit` arguments, option keys and option
//! files without a panic. Nothing is read from or written to the folder:
//! the base path is only joined to the manifest's paths, and no fit runs.
#![no_main]

use std::path::Path;

use hbis::batch::{Shard, Study};
use libfuzzer_sys::fuzz_target;

/// Items enumerated per input at most: the product records x models x
/// seeds of a 4 KiB manifest can reach millions, which is slow, not wrong.
const MAX_ITEMS: usize = 2_000;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let base = Path::new("/tmp/hbis-fuzz-batch");
    let Ok(study) = Study::parse(&text, base) else {
        return;
    };
    let n = study
        .records
        .len()
        .checked_mul(study.models.len())
        .and_then(|n| n.checked_mul(study.seeds.len()));
    if !n.is_some_and(|n| n <= MAX_ITEMS) {
        return;
    }
    let shards = [Shard::ALL, Shard { index: 2, count: 3 }];
    for item in study.items() {
        let _ = item.folder(&study);
        let _ = shards.iter().filter(|s| s.holds(&item)).count();
        let _ = study.fit_args(&item, &base.join("out"));
        for name in ["walkers", "prior", "t0", "map-only"] {
            let _ = study.key_of(&item, name);
        }
        let _ = study.option_files(&item);
    }
});
