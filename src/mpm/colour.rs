//! The node contacts' order for the NLGS: grouped by grain pair (a grain and a wall counts as
//! a pair), the groups coloured so that no two groups of one colour share a grain. The
//! groups of one colour then touch disjoint slots and can be swept on several threads.
//! The order depends on the contacts alone, never on the thread count, so a run's bits do
//! not either (`super::node_contact::nlgs`).

use super::node_contact::{NodeContact, Partner};

/// Groups and colours of the contacts as `order` left them.
#[derive(Clone, Debug, Default)]
pub struct Schedule {
    /// Group `k` is `contacts[groups[k]..groups[k + 1]]`.
    groups: Vec<usize>,
    /// Colour `c` is groups `colours[c]..colours[c + 1]`.
    colours: Vec<usize>,
    /// Whether the last colour is the serial class (its groups may share grains).
    serial: bool,
    /// `order`'s working arrays, kept from step to step: the colours taken at each grain,
    /// and each contact with its colour.
    used: Vec<u64>,
    keyed: Vec<(u32, NodeContact)>,
}

impl Schedule {
    /// Each colour's group boundaries (group `k` is `contacts[b[k]..b[k + 1]]`), and
    /// whether its groups are disjoint (false for the serial class).
    pub fn colours(&self) -> impl Iterator<Item = (&[usize], bool)> + '_ {
        let last = self.colours.len().saturating_sub(2);
        self.colours
            .windows(2)
            .enumerate()
            .map(move |(c, w)| (&self.groups[w[0]..=w[1]], !(self.serial && c == last)))
    }
}

/// Colours past this many share one last class, swept on one thread (a grain would need
/// that many partners).
const SERIAL: u32 = 64;

/// Reorders `contacts` by colour, then grain pair (`a`, partner), then their order before,
/// and records the groups in `schedule`. Each group takes the smallest colour neither of
/// its grains has yet, the groups visited by pair.
pub fn order(contacts: &mut [NodeContact], grains: usize, schedule: &mut Schedule) {
    let pair = |c: &NodeContact| (c.a, c.partner);
    contacts.sort_by_key(pair);
    let used = &mut schedule.used;
    used.clear();
    used.resize(grains, 0);
    let keyed = &mut schedule.keyed;
    keyed.clear();
    let mut start = 0;
    while start < contacts.len() {
        let key = pair(&contacts[start]);
        let end = start + contacts[start..].partition_point(|c| pair(c) == key);
        let b = match key.1 {
            Partner::Grain(b) => Some(b),
            Partner::Wall(_) => None,
        };
        let taken = used[key.0] | b.map_or(0, |b| used[b]);
        let c = (!taken).trailing_zeros().min(SERIAL);
        if c < SERIAL {
            used[key.0] |= 1 << c;
            if let Some(b) = b {
                used[b] |= 1 << c;
            }
        }
        keyed.extend(contacts[start..end].iter().map(|&contact| (c, contact)));
        start = end;
    }
    // stable: within a colour the pairs keep their order, and within a pair its contacts
    keyed.sort_by_key(|(c, _)| *c);
    let keyed = &schedule.keyed;
    schedule.groups.clear();
    schedule.colours.clear();
    schedule.serial = keyed.last().is_some_and(|(c, _)| *c == SERIAL);
    for (k, (c, contact)) in keyed.iter().enumerate() {
        contacts[k] = *contact;
        let new_colour = k == 0 || keyed[k - 1].0 != *c;
        if new_colour || pair(&keyed[k - 1].1) != pair(contact) {
            if new_colour {
                schedule.colours.push(schedule.groups.len());
            }
            schedule.groups.push(k);
        }
    }
    schedule.groups.push(contacts.len());
    schedule.colours.push(schedule.groups.len() - 1);
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    fn contact(node: usize, a: usize, partner: Partner) -> NodeContact {
        NodeContact {
            node,
            a,
            node_a: 0,
            slot_a: 0,
            partner,
            node_b: 0,
            slot_b: 0,
            normal: Vector2::x(),
            gap: 0.0,
            shift: Vector2::zeros(),
            open: 0.0,
            friction: 0.0,
            surface: None,
            force_n: 0.0,
            force_t: 0.0,
        }
    }

    /// Three grains meeting pairwise at shared nodes, a fourth beside them, two on walls:
    /// every contact kept once, a pair's contacts together and in their order, and no
    /// grain twice in one colour.
    #[test]
    fn the_pairs_of_one_colour_share_no_grain() {
        let g = Partner::Grain;
        let mut contacts = vec![
            contact(0, 0, g(1)),
            contact(1, 0, g(2)),
            contact(2, 1, g(2)),
            contact(3, 0, g(1)),
            contact(4, 2, g(3)),
            contact(5, 0, Partner::Wall(0)),
            contact(6, 3, Partner::Wall(0)),
            contact(7, 1, g(2)),
        ];
        let mut schedule = Schedule::default();
        order(&mut contacts, 4, &mut schedule);
        let mut nodes: Vec<usize> = contacts.iter().map(|c| c.node).collect();
        nodes.sort_unstable();
        assert_eq!(nodes, (0..8).collect::<Vec<_>>());
        let mut seen = Vec::new();
        let mut colours = 0;
        for (bounds, disjoint) in schedule.colours() {
            assert!(disjoint);
            colours += 1;
            let mut grains = Vec::new();
            for w in bounds.windows(2) {
                let group = &contacts[w[0]..w[1]];
                let key = (group[0].a, group[0].partner);
                assert!(group.iter().all(|c| (c.a, c.partner) == key));
                assert!(group.windows(2).all(|p| p[0].node < p[1].node));
                assert!(!seen.contains(&key), "{key:?} in two groups");
                seen.push(key);
                grains.push(key.0);
                if let Partner::Grain(b) = key.1 {
                    grains.push(b);
                }
            }
            let n = grains.len();
            grains.sort_unstable();
            grains.dedup();
            assert_eq!(grains.len(), n, "a grain twice in one colour");
        }
        assert_eq!(seen.len(), 6);
        // the triangle 0-1-2 needs three colours
        assert_eq!(colours, 3);
    }
}
