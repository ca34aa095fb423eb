//! A uniform grid over the map, rebuilt every loop by counting sort, so neighbour queries
//! cost what the neighbourhood holds rather than the whole unit count. Entries carry their
//! position at rebuild time, so a query rejects far entries without touching unit data.

use crate::geom::Vec2;

/// Smallest cell side: about the reach of the shortest queries (collisions).
const MIN_CELL: f32 = 2.0;
/// Up to this many entries a query simply visits them all: cheaper than cells.
const BRUTE_FORCE_MAX: usize = 24;

#[derive(Clone, Copy, Debug, Default)]
struct Item {
    pos: Vec2,
    index: u32,
}

#[derive(Clone, Debug, Default)]
pub struct SpatialGrid {
    cell: f32,
    cols: usize,
    rows: usize,
    starts: Vec<u32>,
    items: Vec<Item>,
    cell_of: Vec<u32>,
    fill: Vec<u32>,
    pos: Vec<Vec2>,
    brute: bool,
}

impl SpatialGrid {
    /// A grid for a map of `map_w` x `map_h` cells holding up to `capacity` entries. Cells
    /// are sized so there are about four per entry (never smaller than 2 map units), which
    /// keeps a rebuild proportional to the entries rather than to the map.
    pub fn new(map_w: u32, map_h: u32, capacity: usize) -> Self {
        let area = (map_w * map_h) as f32;
        let cell = (area / (4 * capacity.max(1)) as f32).sqrt().max(MIN_CELL);
        let cols = (map_w as f32 / cell).ceil() as usize + 1;
        let rows = (map_h as f32 / cell).ceil() as usize + 1;
        Self { cell, cols, rows, starts: vec![0; cols * rows + 1], ..Self::default() }
    }

    fn cell(&self, p: Vec2) -> (usize, usize) {
        let cx = ((p.x / self.cell).max(0.0) as usize).min(self.cols - 1);
        let cy = ((p.y / self.cell).max(0.0) as usize).min(self.rows - 1);
        (cx, cy)
    }

    /// Rebuilds from the positions of the entries for which `include` holds.
    pub fn rebuild(&mut self, positions: impl ExactSizeIterator<Item = (Vec2, bool)>) {
        self.brute = positions.len() <= BRUTE_FORCE_MAX;
        self.items.clear();
        if self.brute {
            self.items.extend(positions.enumerate().filter(|(_, (_, inc))| *inc).map(|(i, (pos, _))| Item { pos, index: i as u32 }));
            return;
        }
        self.cell_of.clear();
        self.starts.iter_mut().for_each(|s| *s = 0);
        let mut n = 0;
        let mut pos = std::mem::take(&mut self.pos);
        pos.clear();
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
            pos.push(p);
        }
        for i in 1..self.starts.len() {
            self.starts[i] += self.starts[i - 1];
        }
        self.items.resize(n, Item::default());
        self.fill.clear();
        self.fill.extend_from_slice(&self.starts);
        for (i, &c) in self.cell_of.iter().enumerate() {
            if c != u32::MAX {
                let slot = &mut self.fill[c as usize];
                self.items[*slot as usize] = Item { pos: pos[i], index: i as u32 };
                *slot += 1;
            }
        }
        self.pos = pos;
    }

    /// Calls `f` for (at least) every entry whose position at rebuild time is within `r` of
    /// `p`; callers check exact distances, and pad `r` when entries may have moved since.
    /// Order is deterministic.
    pub fn for_each_near(&self, p: Vec2, r: f32, mut f: impl FnMut(usize)) {
        let r2 = r * r;
        if self.brute {
            // Few entries: the caller's own exact distance check is all the filtering needed.
            self.items.iter().for_each(|it| f(it.index as usize));
            return;
        }
        let (x0, y0) = self.cell(Vec2::new(p.x - r, p.y - r));
        let (x1, y1) = self.cell(Vec2::new(p.x + r, p.y + r));
        for cy in y0..=y1 {
            let row = cy * self.cols;
            // Cells of one row are contiguous in `items`.
            let (a, b) = (self.starts[row + x0] as usize, self.starts[row + x1 + 1] as usize);
            for it in &self.items[a..b] {
                if it.pos.dist_sq(p) <= r2 {
                    f(it.index as usize);
                }
            }
        }
    }

    /// Whether any entry within `r` of `p` (at rebuild time) satisfies `pred`; stops at the
    /// first one. Brute-force mode tests every entry.
    pub fn any_near(&self, p: Vec2, r: f32, mut pred: impl FnMut(usize) -> bool) -> bool {
        if self.brute {
            return self.items.iter().any(|it| pred(it.index as usize));
        }
        let r2 = r * r;
        let (x0, y0) = self.cell(Vec2::new(p.x - r, p.y - r));
        let (x1, y1) = self.cell(Vec2::new(p.x + r, p.y + r));
        (y0..=y1).any(|cy| {
            let row = cy * self.cols;
            let (a, b) = (self.starts[row + x0] as usize, self.starts[row + x1 + 1] as usize);
            self.items[a..b].iter().any(|it| it.pos.dist_sq(p) <= r2 && pred(it.index as usize))
        })
    }
}
