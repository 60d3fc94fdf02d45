//! Calibration of model criticism (`hbis::criticism::calibration`): null
//! records (the truth is the start model; white noise, and coloured,
//! filtered, quantised sensor noise), records with one hidden catalog
//! effect, and records with physics outside the catalog (a memory force,
//! a smooth hysteretic spring, friction heating), each criticised as
//! `hbis diagnose --noise auto` does it. Prints a line per record as it
//! finishes, then the table with the rates and their Clopper-Pearson 95 %
//! intervals.
//!
//! ```sh
//! cargo run --release --features examples --example criticism_calibration -- 20 5 2026 [outcomes.json] [OUTSIDE] [sensor=averaging] [record=INDEX]
//! ```
//! Arguments: null records per noise kind (20), records per hidden effect
//! (5; eight effects), seed (2026), optionally a file for the outcomes as
//! JSON, records per out-of-catalog physics (three kinds; as many as per
//! hidden effect unless given), and `sensor=averaging` to make every
//! record, and fit every model, with the averaging sensor. The tables in
//! the README and docs/criticism.md came from that command. `record=INDEX`
//! criticises only the study's record `INDEX` (its seed is
//! `seed * 1000003 + INDEX`, as in the full study): one line of a study
//! replayed, to see what a change of the code does to it.

use hbis::criticism::calibration::{criticise, standard, study, table, Outcome, Sensor};
use hbis::model::Registry;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (options, args): (Vec<String>, Vec<String>) = std::env::args()
        .skip(1)
        .partition(|a| a.starts_with("sensor=") || a.starts_with("record="));
    let record: Option<usize> = options
        .iter()
        .filter_map(|o| o.strip_prefix("record="))
        .next_back()
        .map(str::parse)
        .transpose()?;
    let sensor = match options
        .iter()
        .rfind(|o| o.starts_with("sensor="))
        .map(String::as_str)
    {
        None | Some("sensor=instant") => Sensor::Instant,
        Some("sensor=averaging") => Sensor::Averaging,
        Some(other) => {
            return Err(format!("{other}: expected sensor=instant or sensor=averaging").into())
        }
    };
    let nulls: usize = args.first().map_or(Ok(20), |s| s.parse())?;
    let per_effect: usize = args.get(1).map_or(Ok(5), |s| s.parse())?;
    let seed: u64 = args.get(2).map_or(Ok(2026), |s| s.parse())?;
    let per_outside: usize = args.get(4).map_or(Ok(per_effect), |s| s.parse())?;
    let clock = std::time::Instant::now();
    let line = |o: &Outcome| {
        eprintln!(
            "[{:6.0} s] {:?} seed {}: noise {}, first {:?} (BIC {:+.1}), accepted {:?}; {}{}",
            clock.elapsed().as_secs_f64(),
            o.kind,
            o.seed,
            o.noise.as_str(),
            o.first,
            o.first_delta_bic,
            o.accepted,
            o.reason,
            // A hidden effect kept out while another was accepted or
            // ranked first: its own gates' words.
            o.hidden_reason
                .as_ref()
                .filter(|r| !o.recovered() && **r != o.reason)
                .map_or(String::new(), |r| format!("; {:?}: {r}", o.hidden))
        )
    };
    let kinds = standard(nulls, per_effect, per_outside);
    let outcomes = match record {
        None => study(&Registry::builtin(), &kinds, sensor, seed, &line)?,
        Some(i) => {
            let kind = *kinds
                .get(i)
                .ok_or_else(|| format!("record={i}: the study has {} records", kinds.len()))?;
            let seed = seed.wrapping_mul(1_000_003).wrapping_add(i as u64);
            let o = criticise(&Registry::builtin(), kind, sensor, seed)?;
            line(&o);
            vec![o]
        }
    };
    println!(
        "criticism calibration: seed {seed}, sensor {sensor:?}, {} records, {:.0} s",
        outcomes.len(),
        clock.elapsed().as_secs_f64()
    );
    print!("{}", table(&outcomes));
    if let Some(path) = args.get(3) {
        std::fs::write(path, serde_json::to_string_pretty(&outcomes)?)?;
    }
    Ok(())
}
