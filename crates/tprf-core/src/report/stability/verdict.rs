//! A row of the stability table, what it checks, its verdict, and the table itself.

use std::fmt::Write as _;

/// Where a row's expected value comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Derived independently of the renderer: a closed form, a quadrature, the renewal
    /// equation, an exact sum.
    Reference,
    /// The renderer's own result on an equivalent input (another scale, another
    /// binning): a check that nothing changes, not a measure of accuracy.
    Invariance,
}

impl Kind {
    /// The words in the table: `independent reference`, `invariance check`.
    pub fn label(self) -> &'static str {
        match self {
            Kind::Reference => "independent reference",
            Kind::Invariance => "invariance check",
        }
    }
}

/// What a row checks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Check {
    /// `|got - expected| <= tolerance`.
    Within { expected: f64, tolerance: f64 },
    /// `got <= bound`.
    AtMost { bound: f64 },
    /// `got > bound`.
    Above { bound: f64 },
}

/// One line of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub case: String,
    pub setting: String,
    /// What the expected value is: an independent reference or the renderer's own.
    pub kind: Kind,
    pub check: Check,
    pub got: f64,
    /// NaN or infinite values in what was rendered.
    pub non_finite: u64,
    /// Where the expected value and the tolerance come from; a documented bias.
    pub note: String,
}

impl Row {
    pub fn passed(&self) -> bool {
        self.non_finite == 0
            && self.got.is_finite()
            && match self.check {
                Check::Within {
                    expected,
                    tolerance,
                } => (self.got - expected).abs() <= tolerance,
                Check::AtMost { bound } => self.got <= bound,
                Check::Above { bound } => self.got > bound,
            }
    }

    /// `|got - expected| / |expected|` where there is an expected value.
    pub fn relative_error(&self) -> Option<f64> {
        match self.check {
            Check::Within { expected, .. } if expected != 0.0 => {
                Some((self.got - expected).abs() / expected.abs())
            }
            _ => None,
        }
    }

    fn expected_text(&self) -> String {
        match self.check {
            Check::Within {
                expected,
                tolerance,
            } => format!("{} ± {}", num(expected), num(tolerance)),
            Check::AtMost { bound } => format!("≤ {}", num(bound)),
            Check::Above { bound } => format!("> {}", num(bound)),
        }
    }
}

/// `x` with 6 decimals, or 6 significant digits outside `[1e-3, 1e5)`.
pub(super) fn num(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&x.abs()) {
        format!("{x:.6}")
    } else {
        format!("{x:.6e}")
    }
}

/// The markdown table of `rows`.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from(
        "| case | setting | expected | got | relative error | NaN/Inf | verdict | kind | notes |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.case,
            r.setting,
            r.expected_text(),
            num(r.got),
            r.relative_error()
                .map_or("-".into(), |e| format!("{:.2e}", e)),
            r.non_finite,
            if r.passed() { "pass" } else { "FAIL" },
            r.kind.label(),
            r.note
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_judge_and_print() {
        let r = Row {
            case: "c".into(),
            setting: "s".into(),
            kind: Kind::Reference,
            check: Check::Within {
                expected: 2.0,
                tolerance: 0.1,
            },
            got: 2.05,
            non_finite: 0,
            note: String::new(),
        };
        assert!(r.passed());
        assert!((r.relative_error().unwrap() - 0.025).abs() < 1e-12);
        let nan = Row {
            got: f64::NAN,
            ..r.clone()
        };
        assert!(!nan.passed());
        let inf = Row {
            non_finite: 1,
            ..r.clone()
        };
        assert!(!inf.passed());
        let t = markdown(&[r, nan]);
        assert!(t.contains("| pass |") && t.contains("| FAIL |"));
        assert!(t.contains("| independent reference |"));
    }
}
