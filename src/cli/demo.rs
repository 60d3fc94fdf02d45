//! `hbis demo`: the Solarino Test 5 of Table 8.1, simulated and drawn.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use hbis::model::physical::Physical;
use hbis::model::{ModelSpec, Params, PhaseKind, Response};
use hbis::report;

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

    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create folder {}", a.out.display()))?;
    let csv_path = a.out.join("test5.csv");
    let f = std::fs::File::create(&csv_path)
        .with_context(|| format!("cannot create {}", csv_path.display()))?;
    report::csv::write_samples(std::io::BufWriter::new(f), &response.sample_grid(DT)?)?;
    writeln!(out, "\nwrote {}", csv_path.display())?;
    if cfg!(feature = "figures") {
        let fig = a.out.join("test5.png");
        figure(
            &fig,
            &response,
            DT,
            "Solarino Test 5 (Table 8.1): closed-form response",
        )?;
        writeln!(out, "wrote {}", fig.display())?;
    }
    Ok(())
}

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
