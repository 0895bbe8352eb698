use super::V2;

/// A uniform cell list over a set of points, built by a counting sort of cell indices so the
/// order inside each cell is the input order (deterministic). Cells are squares of side
/// `cell`; neighbours of a point are found in the 3x3 block of cells around it.
#[derive(Clone, Debug, Default)]
pub struct CellList {
    origin: V2,
    cell: f64,
    nx: usize,
    ny: usize,
    /// `start[c]..start[c + 1]` indexes `items` for cell `c`.
    start: Vec<usize>,
    items: Vec<u32>,
}

impl CellList {
    /// Bins `points` into cells of side at least `cell`. The grid covers the points' bounding box.
    pub fn build(points: &[V2], cell: f64) -> Self {
        let mut list = CellList::default();
        if points.is_empty() {
            return list;
        }
        let (mut lo, mut hi) = (points[0], points[0]);
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        list.origin = lo;
        list.cell = cell;
        // Cap the grid so that a far-flung point cannot allocate a huge array.
        let cap = (4 * points.len()).max(16) as f64;
        list.nx = (((hi.x - lo.x) / cell).floor() as usize + 1).min(cap as usize);
        list.ny = (((hi.y - lo.y) / cell).floor() as usize + 1).min(cap as usize);
        let idx: Vec<usize> = points.iter().map(|p| list.index_of(*p)).collect();
        list.start = vec![0; list.nx * list.ny + 1];
        for &c in &idx {
            list.start[c + 1] += 1;
        }
        for c in 0..list.nx * list.ny {
            list.start[c + 1] += list.start[c];
        }
        let mut fill = list.start.clone();
        list.items = vec![0; points.len()];
        for (k, &c) in idx.iter().enumerate() {
            list.items[fill[c]] = k as u32;
            fill[c] += 1;
        }
        list
    }

    fn coords(&self, p: V2) -> (usize, usize) {
        let cx = ((p.x - self.origin.x) / self.cell).floor().max(0.0) as usize;
        let cy = ((p.y - self.origin.y) / self.cell).floor().max(0.0) as usize;
        (cx.min(self.nx - 1), cy.min(self.ny - 1))
    }

    fn index_of(&self, p: V2) -> usize {
        let (cx, cy) = self.coords(p);
        cy * self.nx + cx
    }

    /// Calls `f(k)` for every point `k` in the 3x3 cells around `p`.
    pub fn for_each_near(&self, p: V2, mut f: impl FnMut(usize)) {
        if self.items.is_empty() {
            return;
        }
        let (cx, cy) = self.coords(p);
        for y in cy.saturating_sub(1)..=(cy + 1).min(self.ny - 1) {
            for x in cx.saturating_sub(1)..=(cx + 1).min(self.nx - 1) {
                let c = y * self.nx + x;
                for &k in &self.items[self.start[c]..self.start[c + 1]] {
                    f(k as usize);
                }
            }
        }
    }
}
