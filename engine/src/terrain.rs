//! Terrain: cliff levels per cell, ramps, the playable rectangle, and the rules ground units
//! follow on it.
//!
//! Heights are in cliff levels (the source maps' 64 raw units per level). A cell whose
//! height is not a whole level is a ramp cell. Ground units step between two neighbouring
//! cells only when their heights differ by less than half a level, so a cliff (a whole level
//! at once) is impassable and a ramp (steps of 1/8 to 3/8 of a level) is not.

use crate::geom::Vec2;

const NEIGHBOURS: [(i64, i64); 8] = [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)];

/// Largest height difference between neighbouring cells a ground unit can step over.
pub const MAX_STEP: f32 = 0.5;

/// The playable rectangle in map units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub left: f32,
    pub bottom: f32,
    pub right: f32,
    pub top: f32,
}

impl Rect {
    pub fn width(&self) -> f32 {
        self.right - self.left
    }
    pub fn height(&self) -> f32 {
        self.top - self.bottom
    }
    pub fn center(&self) -> Vec2 {
        Vec2::new((self.left + self.right) * 0.5, (self.bottom + self.top) * 0.5)
    }
    pub fn contains(&self, p: Vec2) -> bool {
        p.x >= self.left && p.x <= self.right && p.y >= self.bottom && p.y <= self.top
    }
    /// Clamps a point to lie at least `margin` inside the rectangle.
    pub fn clamp(&self, p: Vec2, margin: f32) -> Vec2 {
        let m = margin.min(self.width() * 0.5).min(self.height() * 0.5);
        Vec2::new(p.x.clamp(self.left + m, self.right - m), p.y.clamp(self.bottom + m, self.top - m))
    }
}

/// A validated terrain grid. Cell (cx, cy) covers [cx, cx+1) x [cy, cy+1); row 0 is y = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Terrain {
    width: u32,
    height: u32,
    /// Height in levels per cell; `None` where there is no ground (outside the arena).
    cells: Vec<Option<f32>>,
    playable: Rect,
    /// Per cell, Chebyshev distance (in cells) to the nearest cell from which some step is
    /// blocked (void, cliff edge, map edge): a straight move shorter than this minus one
    /// cannot meet an obstacle, which makes most path checks O(1).
    clearance: Vec<u16>,
    /// Connected region of every cell for ordinary ground units, and for cliff walkers
    /// (`u32::MAX` where there is no ground).
    regions: [Vec<u32>; 2],
}

impl Terrain {
    /// Builds a terrain from per-cell heights, row 0 at y = 0. The caller validated sizes.
    pub(crate) fn new(width: u32, height: u32, cells: Vec<Option<f32>>, playable: Rect) -> Self {
        debug_assert_eq!(cells.len(), (width * height) as usize);
        let mut t = Self { width, height, cells, playable, clearance: Vec::new(), regions: [Vec::new(), Vec::new()] };
        t.clearance = t.compute_clearance();
        t.regions = [t.label_regions(false), t.label_regions(true)];
        t
    }

    fn label_regions(&self, cliff_walk: bool) -> Vec<u32> {
        let (w, h) = (self.width as i64, self.height as i64);
        let mut label = vec![u32::MAX; self.cells.len()];
        let mut next = 0;
        let mut stack = Vec::new();
        for start in 0..self.cells.len() {
            if label[start] != u32::MAX || self.cells[start].is_none() {
                continue;
            }
            label[start] = next;
            stack.push(start);
            while let Some(i) = stack.pop() {
                let (x, y) = (i as i64 % w, i as i64 / w);
                for (dx, dy) in NEIGHBOURS {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w || ny >= h {
                        continue;
                    }
                    let j = (ny * w + nx) as usize;
                    if label[j] == u32::MAX && self.step_ok(i, j, cliff_walk) {
                        label[j] = next;
                        stack.push(j);
                    }
                }
            }
            next += 1;
        }
        label
    }

    /// The point nearest to `to` that a ground unit standing at `from` can walk to: `to`
    /// itself when reachable, else the centre of the closest playable cell of its region.
    pub fn reachable_point(&self, from: Vec2, to: Vec2, cliff_walk: bool) -> Option<Vec2> {
        let regions = &self.regions[cliff_walk as usize];
        let region = regions[self.cell_index(from)?];
        if region == u32::MAX {
            return None;
        }
        if self.walkable(to) && self.cell_index(to).is_some_and(|c| regions[c] == region) {
            return Some(to);
        }
        (0..self.cells.len())
            .filter(|&c| regions[c] == region && self.playable.contains(self.cell_center(c)))
            .map(|c| (self.cell_center(c).dist_sq(to), c))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .map(|(_, c)| self.cell_center(c))
    }

    fn compute_clearance(&self) -> Vec<u16> {
        let (w, h) = (self.width as i64, self.height as i64);
        let n = self.cells.len();
        let mut dist = vec![u16::MAX; n];
        let mut queue = std::collections::VecDeque::new();
        for (i, d) in dist.iter_mut().enumerate() {
            let (x, y) = (i as i64 % w, i as i64 / w);
            let edge = self.cells[i].is_none() || x == 0 || y == 0 || x == w - 1 || y == h - 1;
            let blocked = edge
                || NEIGHBOURS.iter().any(|(dx, dy)| {
                    let (nx, ny) = (x + dx, y + dy);
                    nx >= 0 && ny >= 0 && nx < w && ny < h && !self.can_step(i, (ny * w + nx) as usize)
                });
            if blocked {
                *d = 0;
                queue.push_back(i);
            }
        }
        while let Some(i) = queue.pop_front() {
            let (x, y) = (i as i64 % w, i as i64 / w);
            for (dx, dy) in NEIGHBOURS {
                let (nx, ny) = (x + dx, y + dy);
                if nx >= 0 && ny >= 0 && nx < w && ny < h {
                    let j = (ny * w + nx) as usize;
                    if dist[j] == u16::MAX {
                        dist[j] = dist[i] + 1;
                        queue.push_back(j);
                    }
                }
            }
        }
        dist
    }

    /// Flat ground at level 1 everywhere.
    pub fn flat(width: u32, height: u32, playable: Rect) -> Self {
        Self::new(width, height, vec![Some(1.0); (width * height) as usize], playable)
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    pub fn playable(&self) -> Rect {
        self.playable
    }
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }

    /// The cell index under a point, if on the map.
    pub fn cell_index(&self, p: Vec2) -> Option<usize> {
        if !(p.x >= 0.0 && p.y >= 0.0) {
            return None;
        }
        let (cx, cy) = (p.x as u32, p.y as u32);
        (cx < self.width && cy < self.height).then(|| (cy * self.width + cx) as usize)
    }

    pub fn cell_xy(&self, idx: usize) -> (u32, u32) {
        (idx as u32 % self.width, idx as u32 / self.width)
    }

    pub fn cell_center(&self, idx: usize) -> Vec2 {
        let (x, y) = self.cell_xy(idx);
        Vec2::new(x as f32 + 0.5, y as f32 + 0.5)
    }

    /// Height of a cell in levels (`None`: no ground).
    pub fn cell_height(&self, idx: usize) -> Option<f32> {
        self.cells.get(idx).copied().flatten()
    }

    /// Ground height under a point in levels; 0 where there is no ground.
    pub fn height_at(&self, p: Vec2) -> f32 {
        self.cell_index(p).and_then(|i| self.cells[i]).unwrap_or(0.0)
    }

    pub fn is_ramp(&self, idx: usize) -> bool {
        self.cell_height(idx).is_some_and(|h| h.fract().abs() > 1e-4)
    }

    /// Whether a ground unit's centre may stand at `p`.
    pub fn walkable(&self, p: Vec2) -> bool {
        self.playable.contains(p) && self.cell_index(p).is_some_and(|i| self.cells[i].is_some())
    }

    /// Whether a ground unit may step between two neighbouring cells.
    pub fn can_step(&self, a: usize, b: usize) -> bool {
        match (self.cell_height(a), self.cell_height(b)) {
            (Some(ha), Some(hb)) => (ha - hb).abs() < MAX_STEP,
            _ => false,
        }
    }

    /// Whether a ground unit may move in a straight line from `from` to `to`.
    /// `cliff_walk` units (Colossus) only need ground under them.
    pub fn segment_clear(&self, from: Vec2, to: Vec2, cliff_walk: bool) -> bool {
        let d = to - from;
        if let Some(c) = self.cell_index(from)
            && self.clearance[c] as f32 >= d.len() + 2.0
        {
            return true;
        }
        let steps = (d.len() * 4.0).ceil().max(1.0) as u32;
        let mut prev = match self.cell_index(from) {
            Some(i) => i,
            None => return false,
        };
        for s in 1..=steps {
            let p = from + d * (s as f32 / steps as f32);
            let Some(c) = self.cell_index(p) else { return false };
            if c != prev {
                if !self.step_ok(prev, c, cliff_walk) {
                    return false;
                }
                prev = c;
            }
        }
        true
    }

    /// A move between two cells that may be diagonal neighbours; a diagonal move must not
    /// cut the corner of a blocked orthogonal neighbour.
    pub fn step_ok(&self, a: usize, b: usize, cliff_walk: bool) -> bool {
        let ok = |x: usize, y: usize| {
            if cliff_walk { self.cell_height(x).is_some() && self.cell_height(y).is_some() } else { self.can_step(x, y) }
        };
        if !ok(a, b) {
            return false;
        }
        let (ax, ay) = self.cell_xy(a);
        let (bx, by) = self.cell_xy(b);
        if ax != bx && ay != by {
            let w = self.width as usize;
            let c1 = ay as usize * w + bx as usize;
            let c2 = by as usize * w + ax as usize;
            return ok(a, c1) && ok(c1, b) && ok(a, c2) && ok(c2, b);
        }
        true
    }

    /// Counts of cells by kind: (void, level cells, ramp cells).
    pub fn census(&self) -> (usize, usize, usize) {
        let mut out = (0, 0, 0);
        for (i, c) in self.cells.iter().enumerate() {
            match c {
                None => out.0 += 1,
                Some(_) if self.is_ramp(i) => out.2 += 1,
                Some(_) => out.1 += 1,
            }
        }
        out
    }
}
