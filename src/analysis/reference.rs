//! The figures the paper states, kept as data (`data/paper_reference.csv`) with where they
//! come from, and matched to this run's measures by key and case.

use super::summary::CaseSummary;

/// One stated figure.
#[derive(Clone, Debug, PartialEq)]
pub struct Stated {
    pub key: String,
    /// `single_grain` or `packing`: the kind of case it is about.
    pub kind: String,
    /// The case it applies to: a case name or its start (`bpm`, `mpm-`), or `*` for any.
    pub case: String,
    pub value: f64,
    pub unit: String,
    pub source: String,
    pub statement: String,
}

impl Stated {
    /// Whether it applies to a case: the same kind, and `*`, the same name, or a prefix up
    /// to a `-` (`mpm` matches `mpm-mu0.5`, `bpm-d0.1-0.24` matches `bpm-d0.1-0.24-mu0`).
    pub fn applies_to(&self, c: &CaseSummary) -> bool {
        self.kind == c.kind
            && (self.case == "*"
                || c.case == self.case
                || c.case
                    .strip_prefix(&self.case)
                    .is_some_and(|rest| rest.starts_with('-')))
    }
}

const CSV: &str = include_str!("../../data/paper_reference.csv");

/// The table; its fields hold no commas.
pub fn paper() -> Vec<Stated> {
    CSV.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.splitn(7, ',').collect();
            Stated {
                key: f[0].into(),
                kind: f[1].into(),
                case: f[2].into(),
                value: f[3].parse().expect("a number in data/paper_reference.csv"),
                unit: f[4].into(),
                source: f[5].into(),
                statement: f[6].into(),
            }
        })
        .collect()
}

/// The stated value of `key` for case `c`, if the paper gives one.
pub fn lookup<'a>(table: &'a [Stated], key: &str, c: &CaseSummary) -> Option<&'a Stated> {
    table.iter().find(|s| s.key == key && s.applies_to(c))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn case(name: &str, kind: &str) -> CaseSummary {
        CaseSummary {
            case: name.into(),
            kind: kind.into(),
            ..Default::default()
        }
    }

    #[test]
    fn the_table_parses_and_matches_cases() {
        let t = paper();
        assert!(t.len() >= 15);
        let (p, g) = ("packing", "single_grain");
        assert_eq!(
            lookup(&t, "alpha", &case("bpm-mu0.5", p)).unwrap().value,
            0.27
        );
        assert_eq!(
            lookup(&t, "slope", &case("mpm-mu0", p)).unwrap().value,
            0.08
        );
        assert!(lookup(&t, "slope", &case("bpm-mu0", p)).is_none());
        let fig7b = case("bpm-d0.16-0.26-mu0", g);
        assert_eq!(lookup(&t, "particles", &fig7b).unwrap().value, 1750.0);
        assert!(lookup(&t, "particles", &case("bpm-d0.16-0.2-mu0", g)).is_none());
        assert_eq!(
            lookup(&t, "phi_initial", &case("mpm-mu0", p))
                .unwrap()
                .value,
            0.65
        );
        // a single grain is not held to the packings' figures
        assert!(lookup(&t, "phi_initial", &case("mpm-mu0", g)).is_none());
        assert!(
            t.iter()
                .all(|s| !s.source.is_empty() && !s.statement.is_empty())
        );
        assert!(t.iter().all(|s| s.kind == p || s.kind == g));
    }
}
