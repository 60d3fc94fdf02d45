//! Property tests of the record parser: no input makes it panic, every
//! valid record (uniform time, finite acceleration, optional byte-order
//! mark, CRLF line ends, extra columns, comments) reads back exactly and
//! round-trips through `to_csv`, and a bad row, a gap or an extra sample is
//! reported at its own row of the file.

use hbis::data::{record_warnings, Record};
use proptest::prelude::*;

/// Everything a command does with a record it could read: none may panic.
fn exercise(text: &str) {
    let Ok(rec) = Record::parse(text, 0) else {
        return;
    };
    let _ = rec.outliers();
    let _ = rec.without_outliers();
    let _ = rec.noise_level();
    let _ = rec.to_csv();
    for t0 in [None, Some(0.0), rec.t().first().copied()] {
        if let Ok(al) = rec.aligned(t0) {
            let _ = record_warnings(&rec, &al);
        }
    }
}

/// A valid record file and the samples it holds.
#[derive(Debug, Clone)]
struct Valid {
    t: Vec<f64>,
    a: Vec<f64>,
    /// Lines, without line ends: `lines[0]` is the header; comment and
    /// blank lines may come between the data lines.
    lines: Vec<String>,
    /// Row (line of the file, from 1) of each sample.
    rows: Vec<usize>,
    bom: bool,
    crlf: bool,
    comma: bool,
    /// Position of `t` and `a` among the fields.
    it: usize,
    ia: usize,
    width: usize,
}

impl Valid {
    /// The file's text.
    fn text(&self) -> String {
        let end = if self.crlf { "\r\n" } else { "\n" };
        let mut s = String::new();
        if self.bom {
            s.push('\u{feff}');
        }
        for l in &self.lines {
            s.push_str(l);
            s.push_str(end);
        }
        s
    }

    fn sep(&self) -> &'static str {
        if self.comma {
            ","
        } else {
            " \t"
        }
    }

    /// A data line with `t` and `a` as given (any text).
    fn line(&self, t: &str, a: &str) -> String {
        let fields: Vec<String> = (0..self.width)
            .map(|j| {
                if j == self.it {
                    t.to_string()
                } else if j == self.ia {
                    a.to_string()
                } else {
                    format!("x{j}")
                }
            })
            .collect();
        fields.join(self.sep())
    }

    /// Replaces sample `k`'s line.
    fn set_line(&mut self, k: usize, line: String) {
        let i = self.rows[k] - 1;
        self.lines[i] = line;
    }
}

prop_compose! {
    fn valid()(
        n in 2usize..80,
        dt in 1e-4f64..0.1,
        t0 in -100.0f64..100.0,
        seed_a in proptest::collection::vec(-1e3f64..1e3, 80),
        extra in 0usize..3,
        t_first in any::<bool>(),
        at in 0usize..3,
        bom in any::<bool>(),
        crlf in any::<bool>(),
        comma in any::<bool>(),
        quoted in any::<bool>(),
        notes in proptest::collection::vec(0usize..80, 0..4),
    ) -> Valid {
        let width = extra + 2;
        let it = at.min(width - 2);
        let (it, ia) = if t_first { (it, it + 1) } else { (it + 1, it) };
        let t: Vec<f64> = (0..n).map(|i| t0 + i as f64 * dt).collect();
        let a = seed_a[..n].to_vec();
        let mut v = Valid {
            t: t.clone(),
            a: a.clone(),
            lines: Vec::new(),
            rows: Vec::new(),
            bom,
            crlf,
            comma,
            it,
            ia,
            width,
        };
        let q = |name: &str| if quoted && comma { format!("\"{name}\"") } else { name.to_string() };
        let header = v.line(&q("t"), &q("A"));
        v.lines.push(header);
        for i in 0..n {
            for _ in notes.iter().filter(|&&k| k == i) {
                v.lines.push(if i % 2 == 0 { "# note".into() } else { String::new() });
            }
            let line = v.line(&t[i].to_string(), &a[i].to_string());
            v.lines.push(line);
            v.rows.push(v.lines.len());
        }
        v
    }
}

/// A uniform record of `n` samples as CSV, with samples `gap` left out.
fn csv_without(n: usize, gap: std::ops::Range<usize>, dt: f64, a: &[f64]) -> (String, usize) {
    let mut text = String::from("t,a\n");
    let mut row_after = 0;
    let mut row = 1;
    for i in (0..n).filter(|i| !gap.contains(i)) {
        row += 1;
        if i == gap.end {
            row_after = row;
        }
        text.push_str(&format!("{},{}\n", i as f64 * dt, a[i % a.len()]));
    }
    (text, row_after)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        exercise(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn arbitrary_lines_never_panic(
        lines in proptest::collection::vec("[-+0-9eEinfINFaNt.,#x \t\"\u{feff}]{0,14}", 0..40),
        crlf in any::<bool>(),
    ) {
        exercise(&lines.join(if crlf { "\r\n" } else { "\n" }));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn numeric_noise_around_a_record_never_panics(
        v in valid(),
        junk in proptest::collection::vec((0usize..80, "[-+0-9eE.,NaIf ]{0,10}"), 1..4),
    ) {
        let mut v = v;
        for (k, s) in junk {
            let i = 1 + k % (v.lines.len() - 1);
            v.lines[i] = s;
        }
        exercise(&v.text());
    }

    #[test]
    fn valid_records_read_exactly_and_round_trip(v in valid()) {
        let rec = Record::parse(&v.text(), 2).unwrap();
        prop_assert_eq!(rec.t(), &v.t[..]);
        prop_assert_eq!(rec.a(), &v.a[..]);
        prop_assert_eq!(rec.rows(), &v.rows[..]);
        let csv = rec.to_csv();
        let back = Record::parse(&csv, 2).unwrap();
        prop_assert_eq!(back.t(), rec.t());
        prop_assert_eq!(back.a(), rec.a());
        prop_assert_eq!(back.to_csv(), csv);
    }

    #[test]
    fn a_bad_row_is_named(v in valid(), k in 0usize..80, kind in 0usize..6) {
        let mut v = v;
        let k = k % v.t.len();
        let (t, a) = (v.t[k].to_string(), v.a[k].to_string());
        let (line, expect) = match kind {
            0 => (v.line(&t, "abc"), "column `a`: expected a number, found `abc`"),
            1 => (v.line("1e", &a), "column `t`: expected a number, found `1e`"),
            2 => (v.line(&t, "NaN"), "column `a`: value NaN is not finite"),
            3 => (v.line("-inf", &a), "column `t`: value -inf is not finite"),
            4 => ("7".to_string(), "expected at least"),
            _ => {
                let k2 = k.max(1);
                let previous = v.t[k2 - 1];
                v.set_line(k2, v.line(&previous.to_string(), &v.a[k2].to_string()));
                let row = v.rows[k2];
                let err = Record::parse(&v.text(), 2).unwrap_err().to_string();
                let expect = format!("row {row}: time {previous} s does not increase");
                prop_assert!(err.starts_with(&expect), "{} / {}", err, expect);
                return Ok(());
            }
        };
        v.set_line(k, line);
        let row = v.rows[k];
        let err = Record::parse(&v.text(), 2).unwrap_err().to_string();
        prop_assert!(err.starts_with(&format!("row {row}")), "{} (row {})", err, row);
        prop_assert!(err.contains(expect), "{} / {}", err, expect);
    }

    #[test]
    fn a_gap_is_named_at_the_row_after_it(
        n in 40usize..3000,
        at in 0.0f64..1.0,
        missing in 1usize..6,
        dt in prop::sample::select(vec![0.001, 0.002, 0.005, 0.01, 1.0 / 256.0]),
        a in proptest::collection::vec(-5.0f64..5.0, 1..50),
    ) {
        let start = 1 + ((n - missing - 2) as f64 * at) as usize;
        let (text, row) = csv_without(n, start..start + missing, dt, &a);
        let rec = Record::parse(&text, 2).unwrap();
        let err = rec.aligned(Some(0.0)).unwrap_err().to_string();
        prop_assert!(err.starts_with(&format!("row {row}, column `t`")), "{} (row {})", err, row);
        prop_assert!(err.contains("missing samples?"), "{}", err);
    }

    #[test]
    fn an_extra_sample_is_named_at_its_row(
        n in 40usize..3000,
        at in 0.0f64..1.0,
        frac in 0.05f64..0.85,
        a in proptest::collection::vec(-5.0f64..5.0, 1..50),
    ) {
        let dt = 0.005;
        let k = ((n - 2) as f64 * at) as usize;
        let mut text = String::from("t,a\n");
        for i in 0..n {
            text.push_str(&format!("{},{}\n", i as f64 * dt, a[i % a.len()]));
            if i == k {
                text.push_str(&format!("{},0\n", (i as f64 + frac) * dt));
            }
        }
        let rec = Record::parse(&text, 2).unwrap();
        let err = rec.aligned(Some(0.0)).unwrap_err().to_string();
        let row = k + 3;
        prop_assert!(err.starts_with(&format!("row {row}, column `t`")), "{} (row {})", err, row);
    }
}
