//! `report.html`: one self-contained page per fit, diagnosis or ladder to
//! hand over: the tables, the verdicts in words and the figures inlined as
//! SVG. No script, no style sheet or font from the network: the page is
//! the one file.
//!
//! ```
//! use hbis::report::html::{Page, Section};
//!
//! let mut s = Section::new("Posterior");
//! s.paragraph("rF0 is the weakest parameter <by far>.");
//! s.table(&["parameter", "mean"], vec![vec!["u0".into(), "0.1166".into()]]);
//! let html = Page::new("hbis fit: test5.csv").section(s).render();
//! assert!(html.starts_with("<!DOCTYPE html>"));
//! assert!(html.contains("&lt;by far&gt;"));
//! assert!(!html.contains("http"));
//! ```

use std::fmt::Write as _;

/// Text made safe to place in HTML.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// One part of a page, in order: paragraphs, tables and figures.
#[derive(Debug, Clone, Default)]
pub struct Section {
    heading: String,
    body: String,
}

impl Section {
    /// A section under `heading`.
    pub fn new(heading: &str) -> Self {
        Self {
            heading: heading.to_string(),
            body: String::new(),
        }
    }

    /// A paragraph of plain text.
    pub fn paragraph(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<p>{}</p>", escape(text));
        self
    }

    /// A warning, set apart.
    pub fn warning(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<p class=\"warn\">{}</p>", escape(text));
        self
    }

    /// A table with a header row (none if every title is empty, as for a
    /// two-column list of what and value); numbers are best given already
    /// formatted. A row of empty cells is left out.
    pub fn table(&mut self, header: &[&str], rows: Vec<Vec<String>>) -> &mut Self {
        self.body.push_str("<table>\n");
        if header.iter().any(|h| !h.trim().is_empty()) {
            self.body.push_str("<thead><tr>");
            for h in header {
                let _ = write!(self.body, "<th>{}</th>", escape(h));
            }
            self.body.push_str("</tr></thead>\n");
        }
        self.body.push_str("<tbody>\n");
        for r in rows
            .into_iter()
            .filter(|r| r.iter().any(|c| !c.trim().is_empty()))
        {
            self.body.push_str("<tr>");
            for c in r {
                // Numbers line up on the right, words read from the left.
                if c.trim_start_matches('+').parse::<f64>().is_ok() {
                    let _ = write!(self.body, "<td class=\"n\">{}</td>", escape(&c));
                } else {
                    let _ = write!(self.body, "<td>{}</td>", escape(&c));
                }
            }
            self.body.push_str("</tr>\n");
        }
        self.body.push_str("</tbody></table>\n");
        self
    }

    /// A figure: an SVG document (as a figure function writes it), inlined,
    /// with a caption.
    pub fn figure(&mut self, svg: &str, caption: &str) -> &mut Self {
        // The XML prolog is not allowed inside HTML.
        let start = svg.find("<svg").unwrap_or(0);
        let _ = writeln!(
            self.body,
            "<figure>{}<figcaption>{}</figcaption></figure>",
            &svg[start..],
            escape(caption)
        );
        self
    }
}

/// A whole page.
#[derive(Debug, Clone, Default)]
pub struct Page {
    title: String,
    sections: Vec<Section>,
}

impl Page {
    /// A page titled `title`.
    pub fn new(title: &str) -> Self {
        Self {
            title: title.to_string(),
            sections: Vec::new(),
        }
    }

    /// Adds a section.
    pub fn section(mut self, s: Section) -> Self {
        self.sections.push(s);
        self
    }

    /// The HTML text.
    pub fn render(&self) -> String {
        let mut out = String::new();
        let t = escape(&self.title);
        let _ = write!(
            out,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{t}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{t}</h1>\n"
        );
        out.push_str("<nav><ul>");
        for (i, s) in self.sections.iter().enumerate() {
            let _ = write!(out, "<li><a href=\"#s{i}\">{}</a></li>", escape(&s.heading));
        }
        out.push_str("</ul></nav>\n");
        for (i, s) in self.sections.iter().enumerate() {
            let _ = write!(
                out,
                "<section id=\"s{i}\">\n<h2>{}</h2>\n{}</section>\n",
                escape(&s.heading),
                s.body
            );
        }
        let _ = write!(
            out,
            "<footer>written by hbis {}</footer>\n</body>\n</html>\n",
            env!("CARGO_PKG_VERSION")
        );
        out
    }
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}\
h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}\
table{border-collapse:collapse;margin:1em 0;font-size:.9em}th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left}td.n{text-align:right}thead{background:#f2f2f2}\
figure{margin:1em 0}figure svg{max-width:100%;height:auto}figcaption{font-size:.9em;color:#555}\
.warn{background:#fff4e5;border-left:4px solid #e69500;padding:.4em .8em}\
nav ul{list-style:none;padding:0;display:flex;flex-wrap:wrap;gap:1em}footer{margin-top:3em;font-size:.8em;color:#777}";

/// A number for a table: 6 significant digits, no "-0".
///
/// ```
/// use hbis::report::html::num;
/// assert_eq!(num(0.11660123), "0.116601");
/// assert_eq!(num(-0.0), "0");
/// assert_eq!(num(1333.14159), "1333.14");
/// assert_eq!(num(2.5e-7), "2.5000e-7");
/// ```
pub fn num(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor();
    if !(-3.0..6.0).contains(&mag) {
        format!("{x:.4e}")
    } else {
        let decimals = (5.0 - mag).max(0.0) as usize;
        format!("{x:.decimals$}")
    }
}

/// The page of a fit: what was fitted, the MAP, the posterior with its
/// diagnostics (each parameter with its unit, `units[k]` for `names[k]`),
/// the identifiability report and design table, eq. 8.1's quantities, the
/// warnings and the `figures` (SVG, caption).
pub fn fit_page(
    r: &crate::report::json::FitReport,
    names: &[String],
    units: &[String],
    figures: &[(String, String)],
) -> String {
    let mut about = Section::new("Record and model");
    about.table(
        &["", ""],
        vec![
            vec!["record".into(), r.data.source.clone()],
            vec!["model".into(), r.model.clone()],
            vec!["noise model".into(), r.noise.clone()],
            vec!["seed".into(), r.seed.to_string()],
            vec![
                "samples".into(),
                format!("{} at dt = {} s", r.data.samples, r.data.dt),
            ],
            vec![
                "release".into(),
                format!("t0 = {} s ({})", r.data.t0, r.data.t0_source),
            ],
            vec!["residual level sigma_hat".into(), num(r.sigma_hat)],
        ],
    );
    let warn = warnings_section(&r.warnings);
    let mut post = Section::new("Parameters");
    let rows = names
        .iter()
        .enumerate()
        .map(|(k, n)| {
            let unit = units.get(k).cloned().unwrap_or_else(|| "-".into());
            let mut row = vec![
                n.clone(),
                unit,
                r.map.get(n).map_or(String::new(), |v| num(*v)),
            ];
            if let Some(p) = r.posterior.as_ref().and_then(|p| p.get(n)) {
                row.extend([num(p.mean), num(p.sd), num(p.q05), num(p.q95)]);
                if let Some(s) = &r.sampling {
                    row.push(s.ess.get(n).map_or(String::new(), |v| format!("{v:.0}")));
                    row.push(s.rhat.get(n).map_or(String::new(), |v| format!("{v:.3}")));
                }
            }
            row
        })
        .collect();
    if r.posterior.is_some() {
        post.table(
            &[
                "parameter",
                "unit",
                "MAP",
                "mean",
                "sd",
                "q05",
                "q95",
                "ESS",
                "R-hat",
            ],
            rows,
        );
    } else {
        post.paragraph("MAP only: no posterior was sampled.");
        post.table(&["parameter", "unit", "MAP"], rows);
    }
    if let Some(s) = &r.sampling {
        post.paragraph(&format!(
            "Sampler: {} ensembles x {} walkers, {} steps ({} burn-in), moves {}; {}.",
            s.ensembles,
            s.walkers,
            s.steps,
            s.burn_in,
            s.moves,
            match &s.not_converged {
                None =>
                    "converged (kept chain at least 50 autocorrelation times, split R-hat <= 1.01)"
                        .to_string(),
                Some(why) => format!("NOT converged: {why}"),
            }
        ));
    }
    let mut page = Page::new(&format!("hbis fit: {} with {}", r.data.source, r.model))
        .section(about)
        .section(warn)
        .section(post);
    if let (Some(ranking), Some(expl)) = (&r.ranking, &r.explanation) {
        let mut id = Section::new("Identifiability");
        id.paragraph(&format!(
            "Best to worst determined: {}.",
            ranking.join(", ")
        ));
        id.paragraph(expl);
        if let Some(d) = r.identifiability.as_ref().and_then(|i| i.design.as_ref()) {
            id.paragraph(&d.summary);
        }
        page = page.section(id);
    }
    if let Some(phys) = &r.physical {
        let mut s = Section::new("Physical quantities (eq. 8.1)");
        let units = [
            ("m", "t"),
            ("k0", "kN/m"),
            ("k1", "kN/m"),
            ("k2", "kN/m"),
            ("kF", "kN/m"),
            ("c", "kN s/m"),
        ];
        s.table(
            &["quantity", "unit", "mean", "sd", "q05", "q95"],
            units
                .iter()
                .filter_map(|(n, u)| {
                    phys.get(*n).map(|p| {
                        vec![
                            n.to_string(),
                            u.to_string(),
                            num(p.mean),
                            num(p.sd),
                            num(p.q05),
                            num(p.q95),
                        ]
                    })
                })
                .collect(),
        );
        page = page.section(s);
    }
    if let Some(f) = figures_section(figures) {
        page = page.section(f);
    }
    page.render()
}

/// The candidates of a diagnosis (or a ladder step) as a table.
/// One sentence per candidate screened out by its score test.
fn screened_list(s: &mut Section, screened: &[crate::criticism::Screened]) {
    for c in screened {
        s.paragraph(&format!("{}: {}", c.effect, c.reason));
    }
}

fn candidates_table(s: &mut Section, c: &[crate::criticism::RankedCandidate]) {
    s.table(
        &[
            "effect",
            "e2",
            "delta BIC",
            "delta log-evidence",
            "starts agreeing",
            "accepted",
            "why",
        ],
        c.iter()
            .map(|c| {
                vec![
                    c.effect.clone(),
                    format!("{:.5}", c.e2),
                    format!("{:+.1}", c.delta_bic),
                    format!("{:+.1}", c.delta_log_evidence),
                    format!("{} of {}", c.agreeing, c.starts),
                    if c.accepted { "yes" } else { "no" }.into(),
                    c.reason.clone(),
                ]
            })
            .collect(),
    );
}

fn warnings_section(warnings: &[crate::data::Warning]) -> Section {
    let mut s = Section::new("Warnings");
    if warnings.is_empty() {
        s.paragraph("None.");
    }
    for w in warnings {
        s.warning(&format!("{}: {}", w.code, w.message));
    }
    s
}

fn figures_section(figures: &[(String, String)]) -> Option<Section> {
    if figures.is_empty() {
        return None;
    }
    let mut s = Section::new("Figures");
    for (svg, caption) in figures {
        s.figure(svg, caption);
    }
    Some(s)
}

/// What a diagnosis or ladder page names at its top.
#[derive(Debug, Clone, Copy)]
pub struct CriticismInfo<'a> {
    /// The record, as given.
    pub source: &'a str,
    /// The start model.
    pub model: &'a str,
    /// The seed.
    pub seed: u64,
    /// The noise model, and how `auto` chose it.
    pub noise: &'a str,
    /// The sentence of `--noise auto`'s choice, if made.
    pub noise_choice: Option<&'a str>,
}

fn about(info: &CriticismInfo) -> Section {
    let mut s = Section::new("Record and model");
    s.table(
        &["", ""],
        vec![
            vec!["record".into(), info.source.to_string()],
            vec!["start model".into(), info.model.to_string()],
            vec!["noise model".into(), info.noise.to_string()],
            vec!["seed".into(), info.seed.to_string()],
        ],
    );
    if let Some(c) = info.noise_choice {
        s.paragraph(c);
    }
    s
}

/// The page of `hbis diagnose`: the fit, the verdict on its residual, the
/// conclusion, every candidate ranked and the figures.
pub fn diagnosis_page(
    info: &CriticismInfo,
    fit: &crate::criticism::ModelFit,
    diagnosis: &crate::criticism::Diagnostics,
    candidates: &[crate::criticism::RankedCandidate],
    screened: &[crate::criticism::Screened],
    warnings: &[crate::data::Warning],
    figures: &[(String, String)],
) -> String {
    let caution = crate::criticism::caution(candidates);
    let conclusion = crate::criticism::conclusion(diagnosis, candidates);
    let mut v = Section::new("Verdict");
    v.paragraph(&format!(
        "{}: e2 = {:.5}, BIC = {:.1}, log-evidence = {:.1}.",
        fit.model, fit.e2, fit.bic, fit.log_evidence
    ));
    v.paragraph(&diagnosis.verdict);
    v.paragraph(&conclusion);
    if let Some(c) = &caution {
        v.warning(c);
    }
    let mut c = Section::new("Candidates");
    candidates_table(&mut c, candidates);
    screened_list(&mut c, screened);
    let mut page = Page::new(&format!(
        "hbis diagnose: {} with {}",
        info.source, info.model
    ))
    .section(about(info))
    .section(warnings_section(warnings))
    .section(v)
    .section(c);
    if let Some(f) = figures_section(figures) {
        page = page.section(f);
    }
    page.render()
}

/// The page of `hbis ladder`: the steps, each with its verdict,
/// conclusion and candidates, and the figures.
pub fn ladder_page(
    info: &CriticismInfo,
    steps: &[crate::criticism::Step],
    warnings: &[crate::data::Warning],
    figures: &[(String, String)],
) -> String {
    let mut table = Section::new("Steps");
    table.table(
        &["step", "model", "added", "e2", "BIC", "log-evidence"],
        steps
            .iter()
            .enumerate()
            .map(|(k, s)| {
                vec![
                    k.to_string(),
                    s.model.clone(),
                    s.added.clone().unwrap_or_else(|| "-".into()),
                    format!("{:.5}", s.e2),
                    format!("{:.1}", s.bic),
                    format!("{:.1}", s.log_evidence),
                ]
            })
            .collect(),
    );
    if let Some(last) = steps.last() {
        table.paragraph(&format!("Final model: {}.", last.model));
        table.paragraph(&last.diagnosis.verdict);
        table.paragraph(&last.conclusion);
    }
    let mut page = Page::new(&format!("hbis ladder: {} from {}", info.source, info.model))
        .section(about(info))
        .section(warnings_section(warnings))
        .section(table);
    for (k, s) in steps.iter().enumerate() {
        let mut sec = Section::new(&format!("Step {k}: {}", s.model));
        sec.paragraph(&s.diagnosis.verdict);
        sec.paragraph(&s.conclusion);
        if let Some(c) = &s.caution {
            sec.warning(c);
        }
        candidates_table(&mut sec, &s.candidates);
        screened_list(&mut sec, &s.screened_out);
        page = page.section(sec);
    }
    if let Some(f) = figures_section(figures) {
        page = page.section(f);
    }
    page.render()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_text_and_strips_the_xml_prolog_of_figures() {
        let mut s = Section::new("A & B");
        s.figure("<?xml version=\"1.0\"?>\n<svg width=\"10\"></svg>", "x < y");
        let html = Page::new("t").section(s).render();
        assert!(html.contains("<h2>A &amp; B</h2>"));
        assert!(html.contains("<figure><svg width=\"10\"></svg><figcaption>x &lt; y</figcaption>"));
        assert!(!html.contains("<?xml"));
    }

    #[test]
    fn a_table_of_blank_titles_has_no_header_row_and_blank_rows_are_left_out() {
        let mut s = Section::new("t");
        s.table(
            &["", ""],
            vec![
                vec!["record".into(), "r.csv".into()],
                vec![String::new(), " ".into()],
            ],
        );
        s.table(&["parameter", "unit"], vec![vec!["u0".into(), "m".into()]]);
        let html = Page::new("t").section(s).render();
        assert_eq!(html.matches("<thead>").count(), 1, "{html}");
        assert!(!html.contains("<th></th>"), "{html}");
        assert!(!html.contains("<tr><td></td>"), "{html}");
        assert!(html.contains("<th>parameter</th><th>unit</th>"));
        assert!(html.contains("<tr><td>record</td><td>r.csv</td></tr>"));
    }
}
