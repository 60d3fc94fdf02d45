//! Any bytes, read as UTF-8 (lossy), must make `FileEffect::from_toml`
//! return an effect or an error. An effect it reads is evaluated once at
//! its neutral parameters on a tiny state (its release values, rates and
//! forces: every expression it compiled), then registered beside the
//! built-in components, all without a panic.
#![no_main]

use hbis::model::effect_file::FileEffect;
use hbis::model::{ForceComponent, Forces, Kinematics, Memory, Quantities, Registry};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(effect) = FileEffect::from_toml(&text, "fuzz.toml") else {
        return;
    };
    let theta: Vec<f64> = effect.params().iter().map(|p| p.neutral).collect();
    let _ = effect.check(&theta);
    let q = Quantities { k0: 39.5, u0: 0.1 };
    let mut x = vec![0.0; effect.states().len()];
    effect.release_states(&theta, &q, &mut x);
    let k = Kinematics {
        u: 0.05,
        v: -0.2,
        dir: -1.0,
        travel: 0.05,
    };
    let mem = Memory { t: 0.01, x: &x, q: &q };
    let mut rates = vec![0.0; x.len()];
    effect.rates(&theta, &k, &mem, &mut rates);
    let mut f = Forces {
        spring: 1.0,
        friction: 0.5,
        damper: 0.1,
        extra: 0.0,
    };
    effect.modify_with(&theta, &k, &mem, &mut f);
    let _ = f.accel();
    let mut registry = Registry::builtin();
    let _ = registry.register_file_effect(effect);
});
