//! CSV tables of a simulated response.
//!
//! Columns of the sample table (a contract, see `docs/cli.md`):
//! `t,u,v,a,f_spring,f_friction,f_damper,phase`, forces per unit mass.

use std::io::Write;

use crate::model::{Phase, Sample};

/// Write samples with a header row.
pub fn write_samples<W: Write>(w: W, samples: &[Sample]) -> Result<(), csv::Error> {
    let mut out = csv::Writer::from_writer(w);
    out.write_record([
        "t",
        "u",
        "v",
        "a",
        "f_spring",
        "f_friction",
        "f_damper",
        "phase",
    ])?;
    for s in samples {
        out.write_record([
            fmt(s.t),
            fmt(s.u),
            fmt(s.v),
            fmt(s.a),
            fmt(s.f_spring),
            fmt(s.f_friction),
            fmt(s.f_damper),
            s.phase.as_str().to_string(),
        ])?;
    }
    out.flush()?;
    Ok(())
}

/// Write the phase log: kind, start/end time, start/end displacement,
/// direction.
pub fn write_phases<W: Write>(w: W, phases: &[Phase]) -> Result<(), csv::Error> {
    let mut out = csv::Writer::from_writer(w);
    out.write_record(["kind", "t_start", "t_end", "u_start", "u_end", "direction"])?;
    for p in phases {
        out.write_record([
            p.kind.as_str().to_string(),
            fmt(p.t_start),
            fmt(p.t_end),
            fmt(p.u_start),
            fmt(p.u_end),
            format!("{}", p.dir as i32),
        ])?;
    }
    out.flush()?;
    Ok(())
}

/// Shortest text that reads back to the same f64.
fn fmt(x: f64) -> String {
    format!("{x:?}")
}
