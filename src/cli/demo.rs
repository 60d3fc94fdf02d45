//! `hbis demo`: the Solarino Test 5 of Table 8.1, simulated and drawn; then
//! a synthetic record identified by its MAP.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use hbis::data::synthesize;
use hbis::inference::{MapSettings, Noise, Posterior, SampleSettings};
use hbis::model::physical::Physical;
use hbis::model::response::grid_len;
use hbis::model::{ModelSpec, Params, PhaseKind, Registry, Response};
use hbis::report;
use hbis::report::outdir::OutDir;
use hbis::study::FitOptions;
use rand::{rngs::StdRng, SeedableRng};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Folder for the demo's CSV and figure.
    #[arg(long, default_value = "hbis-demo")]
    out: PathBuf,
}

/// Sampling of the demo record: 10 s at 200 Hz, as the Solarino records.
const DT: f64 = 0.005;
const DURATION: f64 = 10.0;

pub fn run(a: Args) -> Result<()> {
    let spec = ModelSpec::FULL;
    let params = Params::table_8_1(5).context("Table 8.1 has Test 5")?;
    let mut dir = OutDir::open(&a.out, &[], "demo")?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "Solarino Test 5, model {spec}, Table 8.1 parameters:")?;
    for p in spec.param_names() {
        writeln!(
            out,
            "  {:6} = {:>9} {:3}  {}",
            p.as_str(),
            params.get(p),
            p.unit(),
            p.meaning()
        )?;
    }
    let response = Response::simulate(&spec, &params, DURATION)?;
    writeln!(out)?;
    summary(&mut out, &response)?;
    let q = Physical::from_params(&spec, &params, 1180.0, 100.0)?;
    writeln!(
        out,
        "\nPhysical quantities (eq. 8.1, F0^n = 1180 kN, F_fS = 100 kN; Table 8.2 row 5):"
    )?;
    write!(out, "{}", super::convert::table(&q))?;

    let mut csv = Vec::new();
    report::csv::write_samples(&mut csv, &response.sample_grid(DT)?)?;
    dir.write("test5.csv", &csv)?;
    writeln!(out, "\nwrote {}", dir.path("test5.csv").display())?;
    if cfg!(feature = "figures") {
        dir.write_with("test5.png", |tmp| {
            figure(
                tmp,
                &response,
                DT,
                "Solarino Test 5 (Table 8.1): closed-form response",
            )
        })?;
        writeln!(out, "wrote {}", dir.path("test5.png").display())?;
    }
    identify(&mut out, &mut dir)?;
    earthquake(&mut out, &mut dir)?;
    criticize(&mut out, &mut dir)?;
    dir.finish("demo", SEED, &spec.to_string(), None)?;
    Ok(())
}

/// Model criticism: a record made by the full model from Test 8 (the test
/// with the steepest friction slope), fitted from `bilinear+coulomb`, and the
/// ladder that finds what is missing.
fn criticize(out: &mut impl Write, dir: &mut OutDir) -> Result<()> {
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(8)
        .context("Table 8.1 has Test 8")?
        .to_theta(&spec);
    let mut rng = StdRng::seed_from_u64(SEED + 8);
    let syn = synthesize(
        &hbis::model::Model::from(spec),
        &truth,
        DT,
        grid_len(DT, DURATION),
        0.015,
        &mut rng,
    )?;
    dir.write("record-hidden.csv", syn.record.to_csv().as_bytes())?;
    let path = dir.path("record-hidden.csv");
    writeln!(
        out,
        "\nModel criticism: a record with effects hidden from the starting model (made by {spec} from Test 8, \
         1.5 % noise, noise floor e2 = {:.5}), written to {}; start from bilinear+coulomb:",
        syn.noise_floor,
        path.display()
    )?;
    let data = syn.record.aligned(None)?;
    let registry = Registry::builtin();
    let warnings = hbis::data::record_warnings(&syn.record, &data);
    let s = hbis::study::criticize::setup(
        registry.parse("bilinear+coulomb")?,
        data,
        Some(Noise::White),
        SEED,
        &path.display().to_string(),
        warnings,
        &MapSettings::default(),
    )?;
    let ladder =
        super::criticize::ladder_steps(&registry, &s, hbis::study::criticize::MAX_LADDER_STEPS)?;
    super::criticize::print_ladder(out, &ladder.steps)?;
    super::criticize::print_paths(out, &ladder.report.paths)?;
    let ladder_dir = dir.path("ladder");
    dir.set_prefix("ladder");
    hbis::study::criticize::write_ladder(&registry, &ladder, &s, dir)?;
    dir.set_prefix("");
    writeln!(
        out,
        "wrote {} and step-<k>.png, ladder.png, report.html beside it (same as: hbis ladder --data {} --model bilinear+coulomb --seed {SEED} --out {})",
        ladder_dir.join("ladder.json").display(),
        path.display(),
        ladder_dir.display()
    )?;
    Ok(())
}

/// Seed of the demo's synthetic record and of its fit.
const SEED: u64 = 2026;

/// Fits a synthetic record made from Test 3 with 1.5 % noise: the MAP, the
/// posterior and the identifiability report, beside the truth.
fn identify(out: &mut impl Write, dir: &mut OutDir) -> Result<()> {
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(3)
        .context("Table 8.1 has Test 3")?
        .to_theta(&spec);
    let mut rng = StdRng::seed_from_u64(SEED);
    let n = grid_len(DT, DURATION);
    let syn = synthesize(
        &hbis::model::Model::from(spec),
        &truth,
        DT,
        n,
        0.015,
        &mut rng,
    )?;
    dir.write("record.csv", syn.record.to_csv().as_bytes())?;
    let record_path = dir.path("record.csv");
    writeln!(
        out,
        "\nIdentification: a synthetic record from Test 3 (Table 8.1) with 1.5 % noise \
         (sigma = {:.4} m/s^2, noise floor e2 = {:.5}), written to {}",
        syn.sigma,
        syn.noise_floor,
        record_path.display()
    )?;
    let data = syn.record.aligned(None)?;
    let record_warnings = hbis::data::record_warnings(&syn.record, &data);
    let model = hbis::model::Model::from(spec);
    let fit_dir = dir.path("fit");
    let options = FitOptions {
        seed: SEED,
        map: MapSettings::default(),
        sample: Some(SampleSettings::default()),
        checkpoint: Some(fit_dir.join("checkpoint")),
        forces: Some((RELEASED_FORCE_TEST3, STATIC_FRICTION)),
        label: record_path.display().to_string(),
        evidence: false,
        design_target: Some(0.5),
    };
    let fit = super::fit::run_fit(
        model.clone(),
        data,
        Posterior::default_priors(&model, Noise::White),
        Noise::White,
        &options,
    )?;
    super::fit::print_map(out, &fit.map)?;
    super::fit::print_posterior(out, &fit)?;
    writeln!(out, "\nAgainst the truth the record was made from:")?;
    writeln!(
        out,
        "  {:6} {:>12} {:>12} {:>12} {:>26} {:>8}",
        "", "truth", "MAP", "mean", "90 % interval", "covers"
    )?;
    let sums = fit
        .summaries
        .as_ref()
        .context("the demo samples the posterior")?;
    for (((name, v), t), s) in fit
        .map
        .names
        .iter()
        .zip(&fit.map.theta)
        .zip(&truth)
        .zip(sums)
    {
        writeln!(
            out,
            "  {name:6} {t:>12.6} {v:>12.6} {:>12.6} [{:>11.6}, {:>11.6}] {:>8}",
            s.mean,
            s.q05,
            s.q95,
            if s.q05 <= *t && *t <= s.q95 {
                "yes"
            } else {
                "no"
            }
        )?;
    }
    dir.set_prefix("fit");
    let run = hbis::study::outputs::FitRun {
        source: record_path.display().to_string(),
        seed: SEED,
        noise: Noise::White,
        record_warnings,
        chains: Default::default(),
    };
    hbis::study::outputs::write_fit(&fit, dir, &run, Some(&truth))?;
    super::fit::drop_checkpoint(&fit_dir.join("checkpoint"));
    dir.set_prefix("");
    writeln!(
        out,
        "wrote {} and the chains, fit.png, corner.png, trace.png, report.html beside it (same as: hbis fit --data {} --seed {SEED} \
         --released-force {RELEASED_FORCE_TEST3} --static-friction {STATIC_FRICTION} --out {})",
        fit_dir.join("fit.json").display(),
        record_path.display(),
        fit_dir.display()
    )?;
    Ok(())
}

/// The identified posterior under an earthquake: the fit's draws under a
/// synthetic Kanai-Tajimi motion (0.3 g), against a 0.3 m capacity.
fn earthquake(out: &mut impl Write, dir: &mut OutDir) -> Result<()> {
    let fit_dir = dir.path("fit");
    // The manifest is written when the demo finishes: read the fit's files
    // as this run wrote them, each checked.
    let files: Vec<_> = dir
        .written()
        .iter()
        .filter_map(|f| {
            Some(hbis::report::outdir::FileEntry {
                name: f.name.strip_prefix("fit/")?.to_string(),
                ..f.clone()
            })
        })
        .collect();
    let fit = hbis::predict::FitDraws::read_listed(&fit_dir, &Registry::builtin(), &files)?;
    let motion = hbis::data::ground_motion::KanaiTajimi::default().generate(SEED)?;
    let job = hbis::study::prediction::PredictJob {
        model: fit.model.clone(),
        draws: fit.thinned(1000),
        fit: Some(fit_dir.clone()),
        fit_seed: Some(fit.seed),
        params: None,
        motions: vec![motion],
        scale: 1.0,
        fragility_pgas: Vec::new(),
        seed: SEED,
        opts: hbis::predict::PredictOptions {
            tail: 20.0,
            capacity: Some(0.3),
            band_points: 2000,
            cancel: None,
        },
    };
    writeln!(
        out,
        "\nEarthquake: the posterior draws from rest under a synthetic motion"
    )?;
    let pred_dir = dir.path("predict");
    dir.set_prefix("predict");
    let (p, _) = hbis::study::prediction::write_prediction(dir, &job)?;
    dir.set_prefix("");
    super::predict::print_summary(out, &p, &job)?;
    for w in &p.prediction.warnings {
        writeln!(out, "  note: {w}")?;
    }
    writeln!(
        out,
        "wrote {} and draws.csv, band.csv, response.png, peak-displacement.png beside it (same as: hbis predict \
         --fit {} --synthetic --seed {SEED} --capacity 0.3 --out {})",
        pred_dir.join("predict.json").display(),
        fit_dir.display(),
        pred_dir.display()
    )?;
    Ok(())
}

/// Table 8.2: the force released in Test 3 and the static friction (kN).
const RELEASED_FORCE_TEST3: f64 = 1050.0;
const STATIC_FRICTION: f64 = 100.0;

/// The facts a reader checks first: the branches between reversals, peak
/// velocity, residual displacement and the energy balance.
pub fn summary(out: &mut impl Write, r: &Response) -> Result<()> {
    writeln!(out, "Branches between reversals (phases of the spring):")?;
    let mut branch: Vec<PhaseKind> = Vec::new();
    let mut k = 0;
    for p in r.phases() {
        if p.kind == PhaseKind::Rest {
            break;
        }
        if branch.last() != Some(&p.kind) {
            branch.push(p.kind);
        }
        if p.v_end == 0.0 || p.t_end >= r.duration() {
            k += 1;
            let names: Vec<&str> = branch.iter().map(|b| b.as_str()).collect();
            writeln!(
                out,
                "  {k:2}: {}  (ends t = {:.3} s, u = {:+.4} m)",
                names.join(" -> "),
                p.t_end,
                p.u_end
            )?;
            branch.clear();
        }
    }
    writeln!(out, "peak velocity:         {:.4} m/s", r.peak_velocity())?;
    match (r.residual_displacement(), r.rest_time()) {
        (Some(u), Some(t)) => writeln!(
            out,
            "residual displacement: {:.2} mm (at rest from t = {t:.3} s)",
            1e3 * u
        )?,
        _ => writeln!(out, "still moving at t = {:.3} s", r.duration())?,
    }
    let w = r.work();
    writeln!(
        out,
        "work per unit mass (J/kg): spring {:+.6}, slider {:+.6}, damper {:+.6}; imbalance {:.1e}",
        w.spring,
        w.friction,
        w.damper,
        w.relative_imbalance()
    )?;
    Ok(())
}

/// Draw the six-panel figure, or explain why it cannot be drawn.
pub fn figure(path: &Path, response: &Response, dt: f64, title: &str) -> Result<()> {
    super::inputs::ensure_parent(path)?;
    #[cfg(feature = "figures")]
    {
        report::figures::release_test_figure(path, response, dt, None, title)?;
        Ok(())
    }
    #[cfg(not(feature = "figures"))]
    {
        let _ = (response, dt, title);
        anyhow::bail!(
            "cannot write {}: hbis was built without the `figures` feature",
            path.display()
        )
    }
}
