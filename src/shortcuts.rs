//! Work a scene does not need, skipped by default (issue #7), and the switch that turns each
//! skip off so that what it saves can be measured (`softgrain bench`, section `skips`) and
//! its result compared with the full computation (`tests/skips.rs`).
//!
//! `SOFTGRAIN_WITHOUT=warm_start,verlet` in the environment turns those shortcuts off for
//! the whole process; it is read once. A run without a shortcut computes the same thing the
//! long way: bit for bit for `frictionless` and `verlet`; within the solver tolerance for
//! `warm_start` (the iterations start elsewhere), `local_alert` (they sweep another set of
//! open contacts) and `active_nodes` (a larger system). It is a measuring switch, not a
//! setting: checkpoints do not record it.

use std::sync::OnceLock;

/// The environment variable that lists the shortcuts to turn off.
pub const ENV: &str = "SOFTGRAIN_WITHOUT";

/// Which shortcuts are on (all by default).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shortcuts {
    /// CD: a frictionless contact (μ = 0: every BPM bond, frictionless walls and cases)
    /// solves its normal impulse only; no sliding velocity, tangential impulse or spin.
    pub frictionless: bool,
    /// CD: contact impulses start from the previous step's; MPM: the node contacts (single
    /// grain: the active set; packings: the forces) start from the previous step's.
    pub warm_start: bool,
    /// CD: the Verlet pair list is kept until a disk has moved half the skin; without it
    /// the cell list is rebuilt every step.
    pub verlet: bool,
    /// MPM: only the nodes a grain's points reach are numbered, assembled and solved;
    /// without it every node of the grain's grid (single grain) or window (packing) is.
    pub active_nodes: bool,
    /// CD: a contact enters the solve only when its own two bodies can close it within the
    /// step (or it carries an impulse); the rest are checked after the solve and added where
    /// the solution would close them. Without it every pair within the global alert distance
    /// (set by the fastest disk) is solved.
    pub local_alert: bool,
}

impl Default for Shortcuts {
    fn default() -> Self {
        Shortcuts {
            frictionless: true,
            warm_start: true,
            verlet: true,
            active_nodes: true,
            local_alert: true,
        }
    }
}

/// The names `SOFTGRAIN_WITHOUT` accepts.
pub const NAMES: [&str; 5] = [
    "frictionless",
    "warm_start",
    "verlet",
    "active_nodes",
    "local_alert",
];

impl Shortcuts {
    /// Parses a comma-separated list of shortcuts to turn off ("" turns none off).
    pub fn without(list: &str) -> Result<Self, String> {
        let mut s = Shortcuts::default();
        for name in list.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            match name {
                "frictionless" => s.frictionless = false,
                "warm_start" => s.warm_start = false,
                "verlet" => s.verlet = false,
                "active_nodes" => s.active_nodes = false,
                "local_alert" => s.local_alert = false,
                other => {
                    return Err(format!(
                        "{ENV}={list}: unknown shortcut `{other}` (allowed: {})",
                        NAMES.join(", ")
                    ));
                }
            }
        }
        Ok(s)
    }

    /// The shortcuts of this process, from `SOFTGRAIN_WITHOUT`.
    pub fn from_env() -> Result<Self, String> {
        Self::without(&std::env::var(ENV).unwrap_or_default())
    }
}

/// The process's shortcuts. `main` checks the variable first and exits 2 on a bad one; a
/// library user with a bad value gets all shortcuts on and a warning.
pub fn get() -> Shortcuts {
    static CELL: OnceLock<Shortcuts> = OnceLock::new();
    *CELL.get_or_init(|| {
        Shortcuts::from_env().unwrap_or_else(|e| {
            eprintln!("warning: {e}; every shortcut stays on");
            Shortcuts::default()
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_list_turns_off_what_it_names_and_refuses_the_rest() {
        assert_eq!(Shortcuts::without("").unwrap(), Shortcuts::default());
        let s = Shortcuts::without("verlet, warm_start").unwrap();
        assert!(s.frictionless && !s.warm_start && !s.verlet);
        let e = Shortcuts::without("verlet,tangent").unwrap_err();
        assert!(e.contains("SOFTGRAIN_WITHOUT=verlet,tangent") && e.contains("`tangent`"));
    }
}
