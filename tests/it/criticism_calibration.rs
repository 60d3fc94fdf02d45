//! A reduced run of the criticism calibration
//! (`examples/criticism_calibration.rs`, whose full run the README quotes):
//! null records with white and with coloured, filtered, quantised sensor
//! noise, records with a hidden catalog effect, and records with physics
//! outside the catalog (one of each kind), each criticised as `hbis
//! diagnose --noise auto` does it.
//!
//! The targets are at most 2 false discoveries in 40 null records
//! (a rate of 5 %) and the hidden effect first in at least 38 of 40. At a
//! 5 % rate, two or more false discoveries in four null records happen
//! with probability 1.4 %, and two misses in four hidden records too: the
//! bounds below are those for white-noise nulls and hidden effects. Null
//! records with coloured, filtered sensor noise are not held to it: the
//! full run measures how often the ladder adds an effect there (README),
//! and this test only checks that `--noise auto` sees the colour.
//!
//! The records are new at every commit (the seed comes from its hash and
//! is printed; `HBIS_CALIBRATION_SEED=<seed>` replays a run).

use hbis::criticism::calibration::{study, table, Kind, Sensor, HIDDEN, OUTSIDE};
use hbis::model::Registry;

fn hidden(name: &str) -> Kind {
    Kind::Hidden(HIDDEN.iter().position(|h| h.effect == name).unwrap())
}

/// The share of detectable hidden effects not added on six seeds drawn
/// from commits after their code (session 35, docs/criticism.md).
const MISS_RATE: f64 = 18.0 / 160.0;

/// The fewest misses `m` among `n` records with `P(misses > m) <= alpha`
/// when each is missed with probability `rate`.
fn misses_allowed(n: u64, rate: f64, alpha: f64) -> u64 {
    use statrs::distribution::{Binomial, DiscreteCDF};
    let misses = Binomial::new(rate, n).unwrap();
    (0..=n).find(|&m| misses.sf(m) <= alpha).unwrap_or(n)
}

#[test]
fn misses_allowed_are_the_binomial_tails() {
    // At MISS_RATE: P(> 1 of 4) = 6.5 %, P(> 2 of 4) = 0.52 %.
    assert_eq!(misses_allowed(4, MISS_RATE, 0.01), 2);
    assert_eq!(misses_allowed(4, MISS_RATE, 0.1), 1);
    assert_eq!(misses_allowed(4, 0.0, 0.01), 0);
    assert_eq!(misses_allowed(0, 0.5, 0.01), 0);
}

#[test]
fn few_false_discoveries_and_hidden_effects_ranked_first() {
    let kinds = [
        Kind::NullWhite,
        Kind::NullWhite,
        Kind::NullWhite,
        Kind::NullWhite,
        Kind::NullColoured,
        Kind::NullColoured,
        hidden("velocity-friction"),
        hidden("offset"),
        hidden("degradation"),
        hidden("viscous"),
        Kind::Outside(0),
        Kind::Outside(1),
        Kind::Outside(2),
    ];
    assert_eq!(OUTSIDE.len(), 3);
    let (seed, from) = crate::common::commit_seed(11);
    eprintln!("seed {seed} ({from}); replay: HBIS_CALIBRATION_SEED={seed}");
    let outcomes = study(&Registry::builtin(), &kinds, Sensor::Instant, seed, &|_| {}).unwrap();
    eprintln!("{}", table(&outcomes));
    for o in &outcomes {
        eprintln!(
            "{:?}: noise {}, first {:?} ({:+.1}), accepted {:?}; {}",
            o.kind,
            o.noise.as_str(),
            o.first,
            o.first_delta_bic,
            o.accepted,
            o.reason
        );
        if let Some(d) = o.truth_delta_bic {
            eprintln!("    the truth refitted: BIC {d:+.1}");
        }
    }
    let nulls: Vec<_> = outcomes
        .iter()
        .filter(|o| o.kind == Kind::NullWhite)
        .collect();
    let false_discoveries = nulls.iter().filter(|o| o.false_discovery()).count();
    assert!(
        false_discoveries <= 1,
        "{false_discoveries} of {}",
        nulls.len()
    );
    let hidden: Vec<_> = outcomes.iter().filter(|o| o.hidden.is_some()).collect();
    let found = hidden.iter().filter(|o| o.found()).count();
    assert!(found + 1 >= hidden.len(), "{found} of {}", hidden.len());
    // Out-of-catalog physics: one record of each kind. The full runs of
    // 2026-11-29 and 30 (docs/criticism.md) added a catalog stand-in to
    // at most 3 of 10 Maxwell records, 3 of 10 Bouc-Wen springs (seed
    // 932156) and 0 of 10 friction heatings: at 30 %, 30 % and 10 %, all
    // three here get one in 0.9 % of runs. A gate that accepts every best
    // candidate fails it (three of three).
    let outside: Vec<_> = outcomes.iter().filter(|o| o.outside.is_some()).collect();
    let stand_ins = outside.iter().filter(|o| o.false_discovery()).count();
    assert!(
        stand_ins < outside.len(),
        "{stand_ins} of {}",
        outside.len()
    );
    // A hidden effect that BIC can find on its record (the truth, refitted
    // from its own parameters, beats the start model by more than 10) is
    // the one added. Six seeds drawn from commits after their code
    // (session 35, docs/criticism.md) added 142 of 160 such effects, main's
    // code; the misses are records whose residual shows nothing the effect
    // targets, which issue 35's first rule refuses. At that miss rate two
    // misses among four records happen on 6.5 % of commits, and CI drew
    // such a seed four times (291086, 623499, 406529, 437477: each time a
    // white-residual `degradation` and one more). The misses allowed are
    // the fewest whose excess has probability at most 1 % at that rate:
    // two of four. Refusing every candidate fails it whenever three or
    // four are detectable (all four were on each of those seeds).
    let detectable: Vec<_> = hidden.iter().filter(|o| o.detectable()).collect();
    let recovered = detectable.iter().filter(|o| o.recovered()).count();
    let allowed = misses_allowed(detectable.len() as u64, MISS_RATE, 0.01);
    eprintln!(
        "detectable {}, recovered {recovered}, misses allowed {allowed}",
        detectable.len()
    );
    assert!(
        recovered as u64 + allowed >= detectable.len() as u64,
        "{recovered} of {} detectable hidden effects added ({allowed} misses allowed)",
        detectable.len()
    );
    // The coloured records' noise is AR(1) through a filter: `auto` must
    // see it.
    assert!(outcomes
        .iter()
        .filter(|o| o.kind == Kind::NullColoured)
        .all(|o| o.noise == hbis::inference::Noise::Ar1));
}

/// Two null records with sensor noise of the full run (seed 2026, records
/// 11 and 15) to which the ladder used to add an effect that had only
/// found a better basin of the start model's own parameters:
/// `velocity-friction` on record 11 (BIC -46; the start model's fit stood
/// 27 nats below the truth's parameters), `degradation` on record 15 (BIC
/// -95, against the start model refitted on the numerical engine, 47 nats
/// below its closed-form fit of the same model: a reversal 1e-8 s from a
/// sample instant, which the engines put on either side). The start model
/// is now refitted from the part of every candidate that fits better than
/// it, and the better fit of it on either engine is the baseline. Undoing
/// either change adds `degradation` to record 15 again (BIC -70 with the
/// numerical baseline alone; -95 when only the best candidate's part is
/// refitted, which led to a worse fit).
#[test]
fn a_candidate_that_only_finds_a_better_basin_is_not_added() {
    use hbis::criticism::calibration::criticise;
    let registry = Registry::builtin();
    let run = |i: u64| {
        criticise(
            &registry,
            Kind::NullColoured,
            Sensor::Instant,
            2026 * 1_000_003 + i,
        )
        .unwrap()
    };
    let (a, b) = rayon::join(|| run(11), || run(15));
    for o in [&a, &b] {
        eprintln!(
            "seed {}: first {:?} ({:+.1}), accepted {:?}; {}",
            o.seed, o.first, o.first_delta_bic, o.accepted, o.reason
        );
        assert!(!o.false_discovery(), "seed {}: {:?}", o.seed, o.accepted);
    }
}

/// A null record with sensor noise of the out-of-sample run of 2026-11-29
/// (seed 339994, its record 17; docs/criticism.md) to
/// which `velocity-friction` was added: its refit and `friction-decay`'s
/// gained 40 nats each, all of it on the samples either side of the
/// reversals, where an instantaneous sensor's reading steps as a reversal
/// crosses a sample instant; away from them both fitted worse. Beside it,
/// the same run's record 44, with velocity friction hidden (`r_mu` 0.28,
/// `v_t` 0.023 m/s), which must still be added: 58 of its 66 nats lie
/// away from the reversals.
///
/// Since AR(1) fits start `rho` at the residual's correlation (commit
/// 680e10a) the null's gain is gone (its best candidate: BIC +10.6): it
/// came from an AR(1) fit in a worse basin. The rule on the samples away
/// from the reversals is checked by the `Gate` doctest (a gain of BIC
/// -40 with +29.6 away from them is not supported) and its mechanics by
/// `off_jumps`'s unit test; this test keeps both records' verdicts.
#[test]
fn the_records_behind_the_reversal_rule_keep_their_verdicts() {
    use hbis::criticism::calibration::criticise;
    let registry = Registry::builtin();
    let (null, real) = rayon::join(
        || {
            criticise(
                &registry,
                Kind::NullColoured,
                Sensor::Instant,
                339_995_019_999,
            )
            .unwrap()
        },
        || {
            criticise(
                &registry,
                hidden("velocity-friction"),
                Sensor::Instant,
                339_995_020_026,
            )
            .unwrap()
        },
    );
    for o in [&null, &real] {
        eprintln!(
            "seed {}: first {:?} ({:+.1}), accepted {:?}; {}",
            o.seed, o.first, o.first_delta_bic, o.accepted, o.reason
        );
    }
    assert!(!null.false_discovery(), "{:?}", null.accepted);
    assert_eq!(real.accepted.as_deref(), Some("velocity-friction"));
}

/// A null record with sensor noise of the calibration of 2026-12-05 (seed
/// 261492124, its record 5; docs/criticism.md) to which
/// `asymmetric-friction` was added with BIC -112.2, of which only -4.7
/// (4 %) lay away from the reversals, where the candidates at their
/// neutral values gain -6.3 to -6.5. With the support away from them
/// asked to be at least [`OFF_JUMPS_SHARE`] of the whole it is refused;
/// with the bound of 0 that came before the share (`OFF_JUMPS_SHARE` 0)
/// this test fails.
#[test]
fn a_gain_made_almost_only_at_the_reversals_is_not_added() {
    use hbis::criticism::calibration::criticise;
    use hbis::criticism::ranking::OFF_JUMPS_SHARE;
    let o = criticise(
        &Registry::builtin(),
        Kind::NullColoured,
        Sensor::Instant,
        261_492_908_476_377,
    )
    .unwrap();
    eprintln!(
        "seed {} (share asked {OFF_JUMPS_SHARE}): first {:?} ({:+.1}), accepted {:?}; {}",
        o.seed, o.first, o.first_delta_bic, o.accepted, o.reason
    );
    assert!(!o.false_discovery(), "{:?}", o.accepted);
}

/// A record of the out-of-sample run of 2026-11-29 (seed 372848, its
/// record 71; stiffness degradation hidden, `kappa_k` 0.38) whose global
/// fit of the start model ended in a poor basin with `uy` and `zeta0` on
/// their prior bounds, some 1,390 nats below its best: no warm refit of a
/// candidate left that basin (`degradation` gained nothing from `kappa_k`
/// 0 to 1.5), and `asymmetric-friction` ranked first with BIC -383.8. A
/// fit strained against a bound now gets a cold start for every
/// candidate; the current fit improves from their basins, and the
/// candidates are ranked again from it, so none ends far below the model
/// it extends (which a refit warm-started at it cannot do).
#[test]
fn a_fit_strained_against_a_bound_is_searched_again() {
    use hbis::criticism::calibration::make_record;
    use hbis::criticism::{choose_noise, diagnose_model, fit_model};
    use hbis::inference::MapSettings;
    let registry = Registry::builtin();
    let seed = 372_848 * 1_000_003 + 71;
    let made = make_record(&registry, hidden("degradation"), Sensor::Instant, seed).unwrap();
    let (start, data) = (made.start, made.data);
    let settings = MapSettings::default();
    let noise = choose_noise(&start, &data, &settings, seed ^ 0x0A17_0015)
        .unwrap()
        .chosen;
    let first = fit_model(&start, &data, noise, None, &settings, seed).unwrap();
    let (fit, _, ranked) =
        diagnose_model(&registry, &start, &data, noise, &settings, seed).unwrap();
    for c in &ranked {
        eprintln!(
            "{}: delta logL {:+.2}, delta BIC {:+.1}",
            c.effect, c.delta_log_likelihood, c.delta_bic
        );
    }
    eprintln!(
        "seed {seed}: start fit logL {:.1}, after the ranking {:.1}",
        first.log_likelihood, fit.log_likelihood
    );
    assert!(fit.log_likelihood > first.log_likelihood + 1000.0);
    for c in &ranked {
        assert!(c.delta_log_likelihood > -5.0, "{}", c.effect);
    }
}

/// The calibration record of seed `seed` with the catalog effect `name`
/// hidden, criticised under the instantaneous sensor; its outcome printed.
fn hidden_record(name: &str, seed: u64) -> hbis::criticism::calibration::Outcome {
    use hbis::criticism::calibration::criticise;
    let o = criticise(&Registry::builtin(), hidden(name), Sensor::Instant, seed).unwrap();
    eprintln!(
        "seed {}: first {:?} ({:+.1}), accepted {:?}; {}; the hidden effect's own: {:?}",
        o.seed, o.first, o.first_delta_bic, o.accepted, o.reason, o.hidden_reason
    );
    o
}

/// A record of the out-of-sample run of commit 0578903 (seed 787327, its
/// record 96; the third spring branch hidden, AR(1) noise chosen): the
/// missing branch showed in the jumps at the reversals (where the mass
/// turns at its largest displacements), not in the periods `trilinear`
/// targets. Its refit (BIC -550.0) turned the residual white, was refused
/// as its period features grew, and `friction-decay` (BIC -14.7, `kappa_F`
/// 4.98 against a bound at 5) was added in its place. A refit that turns a
/// coloured residual white explains it: without that rule the record gets
/// `friction-decay` again.
#[test]
fn a_refit_that_turns_the_residual_white_explains_it() {
    let o = hidden_record("trilinear", 787_329_362_077);
    assert_eq!(o.accepted.as_deref(), Some("trilinear"), "{}", o.reason);
    assert!(o.reason.contains("turns white"), "{}", o.reason);
    // The hidden effect's own reason is the accepted one's.
    assert_eq!(o.hidden_reason.as_deref(), Some(o.reason.as_str()));
}

/// A hidden velocity friction on white noise (calibration seed 243288580,
/// record 25; `r_mu` 0.23, `v_t` 0.036 m/s): its refit (BIC -94.4) took
/// the residual's Ljung-Box `Q` from 36.3, coloured at 5 % though not
/// reported at 1 %, to 13.1, while its declared structures (jumps, decay)
/// were below significance before and after. Coloured and white are
/// judged at the same 5 %: with colour asked at 1 % before, it is refused
/// ("goes from 0.001 to 0.001").
#[test]
fn a_residual_coloured_at_five_percent_turned_white_is_explained() {
    let o = hidden_record("velocity-friction", 243_289_309_865_765);
    assert_eq!(
        o.accepted.as_deref(),
        Some("velocity-friction"),
        "{}",
        o.reason
    );
    assert!(o.reason.contains("turns white"), "{}", o.reason);
}

/// A hidden damper (a record of the out-of-sample run of commit d522cae,
/// seed 223489198, its record 110; AR(1) noise chosen at the start model,
/// which stands friction growing with amplitude in for the damping):
/// `viscous` ranked first (BIC -509.8) but was refused because its refit,
/// at the true parameters to 1 %, showed the jumps at reversals 62 %
/// larger in the record than in the model at 3.26 standard errors, and
/// `velocity-friction` (-487.4) was added in its place. Noise alone made
/// those jumps: a structure counts as gained only beyond
/// `ranking::GAINED_Z` (3.40, three standard errors Bonferroni-corrected
/// over the four structures with one).
#[test]
fn a_structure_noise_makes_at_three_standard_errors_does_not_refuse_the_truth() {
    let o = hidden_record("viscous", 223_489_868_467_704);
    assert_eq!(
        o.accepted.as_deref(),
        Some("viscous"),
        "{:?}",
        o.hidden_reason
    );
}

/// A record with white noise and an accelerometer offset the start model
/// lacks (seed 910000000015, drawn by hand on 2026-11-29 for the noise
/// probe of `choose_noise`'s doc): AR(1) fits the misfitted start model
/// with a BIC some 1,700 lower than white noise at the same raw `e2`
/// (`rho` near 0.76), and is chosen, but the residual's sample-to-sample
/// changes are white (`rho` near 0 from them), and the noise choice says
/// that the correlation it fits is a slow misfit. (Choosing white noise
/// there made the calibration worse: docs/criticism.md.)
#[test]
fn ar1_that_only_fits_a_slow_misfit_is_said_to() {
    use hbis::inference::Noise;
    let c = noise_choice(hidden("offset"), 910_000_000_015);
    assert!(c.bic_ar1 < c.bic_white - 100.0, "{}", c.sentence());
    assert!(c.raw_e2_ratio <= c.raw_e2_limit, "{}", c.sentence());
    assert!(c.rho_short.abs() < c.rho_short_limit, "{}", c.sentence());
    assert_eq!(c.chosen, Noise::Ar1, "{}", c.sentence());
    assert!(c
        .sentence()
        .contains("sample-to-sample changes show no colour"));
}

/// `--noise auto`'s choice on the calibration record `kind`, `seed`, as
/// the calibration makes it; printed.
fn noise_choice(kind: Kind, seed: u64) -> hbis::criticism::NoiseChoice {
    use hbis::criticism::calibration::make_record;
    use hbis::criticism::choose_noise;
    use hbis::inference::MapSettings;
    let made = make_record(&Registry::builtin(), kind, Sensor::Instant, seed).unwrap();
    let c = choose_noise(
        &made.start,
        &made.data,
        &MapSettings::default(),
        seed ^ 0x0A17_0015,
    )
    .unwrap();
    eprintln!(
        "seed {seed}: {} (raw e2 ratio {:.4}, limit {:.4})",
        c.sentence(),
        c.raw_e2_ratio,
        c.raw_e2_limit
    );
    c
}

/// A null record with sensor noise of CI's run of commit 6f10807 (seed
/// 352442, record 4) for which `--noise auto` chose white noise: the AR(1)
/// fit (`rho` 0.83) was 1,987 lower in BIC, but its raw `e2` was 1.119
/// times the white fit's, beyond the 1.095 white noise explains on 2,001
/// samples. The noise's colour shows from one sample to the next, so the
/// limit is that of noise of the fit's `rho` (1.31): AR(1).
#[test]
fn the_raw_e2_limit_of_coloured_noise_is_its_colours() {
    use hbis::inference::Noise;
    let c = noise_choice(Kind::NullColoured, 352_443_057_330);
    assert!(c.rho_short > c.rho_short_limit, "{}", c.sentence());
    // Beyond white noise's limit: the colour's is what lets AR(1) in.
    assert!(c.raw_e2_ratio > 1.0 + 3.0 * (2.0f64 / 2001.0).sqrt());
    assert!(c.bic_ar1 < c.bic_white - 100.0, "{}", c.sentence());
    assert_eq!(c.chosen, Noise::Ar1, "{}", c.sentence());
}

/// Two null records with sensor noise (AR(1) through a filter) of the
/// out-of-sample run of commit bb57b25 (seed 86683, records 52 and 54)
/// for which `--noise auto` chose white noise: the AR(1) search, started
/// at `rho = 0` from the white fit, ended with a raw `e2` 2.06 and 4.04
/// times the white fit's (66 to 138 nats below the white fit's parameters
/// with `rho` near 0.81), beyond what the noise explains. Started from
/// the residual's lag-1 correlation it reaches that basin and is chosen.
#[test]
fn coloured_sensor_noise_is_seen_from_a_start_at_the_residuals_correlation() {
    use hbis::inference::Noise;
    let run = |seed: u64| noise_choice(Kind::NullColoured, seed);
    let (a, b) = rayon::join(|| run(86683260054), || run(86683260064));
    for c in [a, b] {
        assert_eq!(c.chosen, Noise::Ar1);
        assert!(c.raw_e2_ratio < 1.02, "{}", c.raw_e2_ratio);
        // Coloured from one sample to the next: sensor noise, not a misfit.
        assert!(c.rho_short > c.rho_short_limit, "{}", c.sentence());
    }
}

/// A record of the out-of-sample run of 2026-11-29 (seed 552985, from
/// commit e3d7879; docs/criticism.md) with a viscoelastic (Maxwell)
/// element in the rubber, outside the default catalog: `r_m` 0.202,
/// `tau_m` 1.47 s. `velocity-friction` gains BIC -104 on it, but only by
/// removing a period error that grows with amplitude, which velocity
/// friction does not produce: it stands in for the memory force and must
/// not be added (nor anything else).
#[test]
fn a_memory_force_gets_no_catalog_stand_in() {
    let o = maxwell_record(552_986_659_075);
    // The memory force shows: some catalog effect gains a lot.
    assert!(o.first_delta_bic < -50.0, "{}", o.first_delta_bic);
    assert!(!o.false_discovery(), "{:?}: {}", o.accepted, o.reason);
}

/// A record of a calibration run of `kind`, criticised as the
/// calibration does (instantaneous sensor); printed.
fn criticised(kind: Kind, seed: u64) -> hbis::criticism::calibration::Outcome {
    let o =
        hbis::criticism::calibration::criticise(&Registry::builtin(), kind, Sensor::Instant, seed)
            .unwrap();
    eprintln!(
        "{seed}: {:?} {:?} {:?}: first {:?} ({:+.1}), accepted {:?}; {}",
        o.hidden, o.outside, o.hidden_values, o.first, o.first_delta_bic, o.accepted, o.reason
    );
    o
}

/// A Maxwell record of a calibration run ([`criticised`]).
fn maxwell_record(seed: u64) -> hbis::criticism::calibration::Outcome {
    let o = criticised(Kind::Outside(0), seed);
    assert_eq!(o.outside.as_deref(), Some("maxwell"));
    o
}

/// Another Maxwell record of that run (`r_m` 0.105, `tau_m` 0.66 s), on
/// which `friction-decay` passed every other gate (BIC -31.5) and was
/// added. The missing form of the start fit names a memory term that
/// lowers BIC by far more, and with that term in both models
/// `friction-decay` gains nothing: it is a stand-in and must be refused
/// on that ground (`Gate::remains`).
#[test]
fn a_candidate_the_missing_forms_memory_term_explains_is_refused() {
    refused_as_stand_in_for(552_986_659_078, "memory term");
}

/// The Maxwell record `seed`'s best candidate lowers BIC by more than 10
/// and is refused as a stand-in for the missing form's `term`.
fn refused_as_stand_in_for(seed: u64, term: &str) {
    let o = maxwell_record(seed);
    assert!(o.first_delta_bic < -10.0, "{}", o.first_delta_bic);
    assert!(!o.false_discovery(), "{:?}: {}", o.accepted, o.reason);
    assert!(o.reason.contains(term), "{}", o.reason);
}

/// A Maxwell record of the run on seed 225710 (`r_m` 0.099, `tau_m` 0.26
/// s), on which `friction-decay` (BIC -106.6) passed gates 1-7 and was
/// added. The missing form of the start fit is one elastic term, `u^3`,
/// which lowers BIC by 148.3: with the tri-linear spring in the model and
/// no other spring law offered, no catalog component makes it, and beside
/// it `friction-decay` gains nothing (BIC +3.4). Gate 8 asked only of
/// memory-led forms added it.
#[test]
fn a_candidate_the_missing_forms_elastic_term_explains_is_refused() {
    refused_as_stand_in_for(225_710_677_247, "elastic term");
}

/// A Maxwell record of the run on seed 17530 (record 117: `r_m` 0.30,
/// `tau_m` 1.00 s), on which `velocity-friction` (BIC -58.3) was added.
/// The missing form leads with `travel u`, then a memory term of 0.97 s
/// that alone lowered BIC by 679.0, more than [`MEMORY_LEAD`] times any
/// candidate's change; beside it `velocity-friction` changed BIC by
/// +15.0, and gate 8, asked only of memory-led forms, added it. Since
/// refits converge (searches from a refit's best until one gains at most
/// one nat, 2026-12-02), `velocity-friction`'s refit (BIC -59.7) no
/// longer has the evidence (log-evidence -4.4) and is refused before gate
/// 8 is asked: the test now checks the stand-in is refused, whatever the
/// gate.
///
/// [`MEMORY_LEAD`]: hbis::criticism::ranking::MEMORY_LEAD
#[test]
fn a_stand_in_for_a_memory_force_beside_travel_is_refused() {
    let o = maxwell_record(17_530_052_707);
    assert!(o.first_delta_bic < -10.0, "{}", o.first_delta_bic);
    assert!(!o.false_discovery(), "{:?}: {}", o.accepted, o.reason);
}

/// The start model's fit searches again where its global search's runs
/// never reached their best value twice: on a Maxwell record of the
/// generator (707334200) the first search with seed 1 ended some 85 nats
/// below the best of six fits (docs/criticism.md, 2026-11-30).
#[test]
fn a_start_fit_whose_runs_disagree_is_searched_again() {
    use hbis::criticism::calibration::make_record;
    use hbis::criticism::ranking::{choose_noise, fit_model, start_fit};
    use hbis::inference::map::MapSettings;
    let registry = Registry::builtin();
    let settings = MapSettings::default();
    let seed = 707_334_200;
    let made = make_record(&registry, Kind::Outside(0), Sensor::Instant, seed).unwrap();
    let noise = choose_noise(&made.start, &made.data, &settings, seed ^ 0x0A17_0015)
        .unwrap()
        .chosen;
    let once = fit_model(&made.start, &made.data, noise, None, &settings, 1).unwrap();
    let start = start_fit(&made.start, &made.data, noise, &settings, 1).unwrap();
    eprintln!(
        "one search: log-likelihood {:.2}, best repeated {:?}; start fit {:.2} ({} evaluations)",
        once.log_likelihood, once.best_repeated, start.log_likelihood, start.evaluations
    );
    assert_eq!(once.best_repeated, Some(false));
    assert!(start.log_likelihood > once.log_likelihood + 10.0);
}

/// A Maxwell record of the out-of-sample run of commit ea72fef (seed
/// 245837807, its record 58: `r_m` 0.246, `tau_m` 0.216 s; AR(1) noise
/// chosen). The missing form's regression, linear about a model that
/// lacks the force, named `u^3` and `|u| u` (BIC -34.0), with which
/// `friction-decay` (-25.6) still gained, and it was added. The memory
/// search of the form (`MissingForm::memory_search`) finds a memory term
/// near 0.2 s that lowers BIC by more than 100, and beside it
/// `friction-decay` gains nothing: without that search in gate 8 the
/// record gets `friction-decay` again.
#[test]
fn a_catalog_effect_that_stands_in_for_a_memory_force_the_form_misses_is_refused() {
    let o = maxwell_record(245_837_807u64.wrapping_mul(1_000_003) + 58);
    assert!(!o.false_discovery(), "{:?}: {}", o.accepted, o.reason);
    assert!(o.reason.contains("memory term"), "{}", o.reason);
}

/// A Maxwell record of the calibration of 2026-12-06 (seed 235684487, its
/// record 56: `r_m` 0.171, `tau_m` 0.73 s; AR(1) noise chosen). The memory
/// search found a term of 0.81 s lowering BIC by 690, but gate 8 refitted
/// the model with it from the current fit's values, not from the search's
/// refit, and ended 126 higher; beside that weaker fit `friction-decay`
/// (BIC -12.9) still gained 16.5, and was added. From the search's refit
/// (`OutOfCatalog::fitted`) the term lowers BIC by 674 and
/// `friction-decay` changes it by +7.6 beside it.
#[test]
fn a_stand_in_is_judged_beside_the_memory_search_at_its_own_fit() {
    let o = maxwell_record(235_684_487u64.wrapping_mul(1_000_003) + 56);
    assert!(!o.false_discovery(), "{:?}: {}", o.accepted, o.reason);
}

/// A hidden damper of the same calibration (its record 53, AR(1) noise
/// chosen): the memory search's term relaxes in 0.035 s, a damper at
/// these frequencies, and lowers BIC by 929.7 against `viscous`'s 928.2.
/// Refitted from the search's own fit, the record cannot tell the two
/// apart, and `viscous` was refused beside it; a term faster than the
/// library's shortest time constant is not asked
/// (`MissingForm::memory_search`).
#[test]
fn a_missing_damper_is_not_refused_beside_a_memory_term_that_is_one() {
    let o = criticised(Kind::Hidden(7), 235_684_487u64.wrapping_mul(1_000_003) + 53);
    assert_eq!(o.hidden.as_deref(), Some("viscous"));
    assert!(o.recovered(), "{:?}: {}", o.accepted, o.reason);
}

/// A Bouc-Wen spring of the calibration of 2026-12-06 (seed 176469212,
/// its record 63): `asymmetric-friction` (BIC -13.7) was added because
/// its refit moved the Ljung-Box `Q` from 41.9 to 33.8, across the 1 %
/// line at which the colour is reported, though still coloured at 5 %
/// (p 0.027): a residual that turns white must be white at 5 %
/// (`ranking::whitened`).
#[test]
fn a_stand_in_that_moves_the_colour_across_its_line_by_a_hair_is_not_added() {
    let o = criticised(Kind::Outside(1), 176_469_741_407_699);
    assert_eq!(o.outside.as_deref(), Some("bouc-wen"));
    assert_eq!(o.first.as_deref(), Some("asymmetric-friction"));
    assert!(!o.false_discovery(), "{:?}: {}", o.accepted, o.reason);
}

/// A Bouc-Wen spring of the calibration of 2026-12-07 (seed 226831318,
/// its record 62; AR(1) noise chosen, the missing form empty):
/// `asymmetric-friction` (BIC -54.9) was added through "the residual
/// turns white" (`Q` 42.8 to 26.6) with `a_F` at 0.79999, on its prior
/// bound 0.8. A candidate whose own size sits on its bound stands in for
/// a force it does not model (`ranking::own_bound`).
#[test]
fn an_effect_that_wants_more_than_its_range_is_not_added() {
    let o = criticised(
        Kind::Outside(1),
        226_831_318u64.wrapping_mul(1_000_003) + 62,
    );
    assert_eq!(o.outside.as_deref(), Some("bouc-wen"));
    assert!(!o.false_discovery(), "{:?}: {}", o.accepted, o.reason);
    assert!(
        o.reason.contains("own `a_F` on its prior bound"),
        "{}",
        o.reason
    );
}

/// A Maxwell record of the out-of-sample run of commit 6e67633 (seed
/// 115766835, its record 59: `r_m` 0.248, `tau_m` 0.74 s; AR(1) noise
/// chosen). The missing form was `travel u` alone with a positive
/// coefficient (BIC -95.7): a stiffness that grows as the test goes on,
/// which no catalog component makes (`degradation` only softens, and its
/// refit stayed at neutral). Taken for a catalog term, the form let
/// `friction-decay` (BIC -47.8) in. Outside the catalog, it has gate 8
/// run the memory search, whose term of about 0.78 s lowers BIC by 350,
/// and beside it `friction-decay` gains nothing.
#[test]
fn a_stiffening_with_travel_is_no_catalog_term() {
    let o = maxwell_record(115_766_835u64.wrapping_mul(1_000_003) + 59);
    assert!(o.first_delta_bic < -10.0, "{}", o.first_delta_bic);
    assert!(!o.false_discovery(), "{:?}: {}", o.accepted, o.reason);
    assert!(o.reason.contains("memory term"), "{}", o.reason);
}

/// A hidden velocity friction of the calibration of 2026-12-07 (seed
/// 71403623, its record 24: `r_mu` 0.32, `v_t` 0.033 m/s; AR(1) noise
/// chosen): BIC fell by 139.1 and the Laplace log-evidence by 14.7, so
/// the evidence gate refused it. The likelihood there is a staircase of
/// some 4.8-nat steps, and the scales the Hessian is taken over were a
/// cell's width (sds of 1e-9); the fall they are measured at now clears
/// the steps (`laplace::scale_drop`).
#[test]
fn an_evidence_over_a_staircase_sees_the_bulk() {
    let o = hidden_record("velocity-friction", 71_403_623 * 1_000_003 + 24);
    assert_eq!(
        o.accepted.as_deref(),
        Some("velocity-friction"),
        "{}",
        o.reason
    );
}
