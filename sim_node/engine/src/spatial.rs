//! A uniform grid over the map, rebuilt every loop by counting sort, so neighbour queries
//! cost what the neighbourhood holds rather than the whole unit count.

use crate::geom::Vec2;

const CELL: f32 = 2.0;
/// Up to this many entries a query simply visits them all: cheaper than cells.
const BRUTE_FORCE_MAX: usize = 24;

#[derive(Clone, Debug, Default)]
pub struct SpatialGrid {
    cols: usize,
    rows: usize,
    starts: Vec<u32>,
    items: Vec<u16>,
    cell_of: Vec<u32>,
    fill: Vec<u32>,
    brute: bool,
}

impl SpatialGrid {
    pub fn new(map_w: u32, map_h: u32) -> Self {
        let cols = (map_w as f32 / CELL).ceil() as usize + 1;
        let rows = (map_h as f32 / CELL).ceil() as usize + 1;
        Self { cols, rows, starts: vec![0; cols * rows + 1], items: Vec::new(), cell_of: Vec::new(), fill: Vec::new(), brute: false }
    }

    fn cell(&self, p: Vec2) -> (usize, usize) {
        let cx = ((p.x / CELL).max(0.0) as usize).min(self.cols - 1);
        let cy = ((p.y / CELL).max(0.0) as usize).min(self.rows - 1);
        (cx, cy)
    }

    /// Rebuilds from the positions of the entries for which `include` holds.
    pub fn rebuild(&mut self, positions: impl ExactSizeIterator<Item = (Vec2, bool)>) {
        self.brute = positions.len() <= BRUTE_FORCE_MAX;
        if self.brute {
            self.items.clear();
            self.items.extend(positions.enumerate().filter(|(_, (_, inc))| *inc).map(|(i, _)| i as u16));
            return;
        }
        self.cell_of.clear();
        self.starts.iter_mut().for_each(|s| *s = 0);
        let mut n = 0;
        for (p, include) in positions {
            let c = if include {
                let (cx, cy) = self.cell(p);
                let c = cy * self.cols + cx;
                self.starts[c + 1] += 1;
                n += 1;
                c as u32
            } else {
                u32::MAX
            };
            self.cell_of.push(c);
        }
        for i in 1..self.starts.len() {
            self.starts[i] += self.starts[i - 1];
        }
        self.items.clear();
        self.items.resize(n, 0);
        self.fill.clear();
        self.fill.extend_from_slice(&self.starts);
        for (i, &c) in self.cell_of.iter().enumerate() {
            if c != u32::MAX {
                let slot = &mut self.fill[c as usize];
                self.items[*slot as usize] = i as u16;
                *slot += 1;
            }
        }
    }

    /// Calls `f` for every entry whose grid cell overlaps the circle (a superset of the
    /// entries within `r` of `p`; callers check exact distances). Order is deterministic.
    pub fn for_each_near(&self, p: Vec2, r: f32, mut f: impl FnMut(usize)) {
        if self.brute {
            self.items.iter().for_each(|&i| f(i as usize));
            return;
        }
        let (x0, y0) = self.cell(Vec2::new(p.x - r, p.y - r));
        let (x1, y1) = self.cell(Vec2::new(p.x + r, p.y + r));
        for cy in y0..=y1 {
            let row = cy * self.cols;
            for cx in x0..=x1 {
                let c = row + cx;
                for &i in &self.items[self.starts[c] as usize..self.starts[c + 1] as usize] {
                    f(i as usize);
                }
            }
        }
    }
}
