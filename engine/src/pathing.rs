//! Ground path finding: a straight line when the terrain allows it, otherwise a flow field
//! (Dijkstra from the goal cell over 8-connected cells) shared by every unit heading to the
//! same cell. Fields are cached per goal; eviction is by insertion order so results never
//! depend on anything but the sequence of requests.

use crate::geom::Vec2;
use crate::terrain::Terrain;
use std::collections::{BTreeMap, BinaryHeap, VecDeque};
use std::sync::Arc;

const MAX_CACHED: usize = 96;
const UNREACHABLE: f32 = f32::INFINITY;

/// Distances to one goal cell, for one movement class.
#[derive(Debug)]
pub struct FlowField {
    dist: Vec<f32>,
}

#[derive(Clone, Debug, Default)]
pub struct PathCache {
    fields: BTreeMap<(u32, bool), Arc<FlowField>>,
    order: VecDeque<(u32, bool)>,
}

#[derive(PartialEq)]
struct Node(f32, u32);
impl Eq for Node {}
impl PartialOrd for Node {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Node {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        // Min-heap on distance, ties broken by cell index for determinism.
        o.0.total_cmp(&self.0).then_with(|| o.1.cmp(&self.1))
    }
}

impl FlowField {
    fn build(t: &Terrain, goal: usize, cliff_walk: bool) -> Self {
        let n = t.cell_count();
        let mut dist = vec![UNREACHABLE; n];
        let w = t.width() as i64;
        let h = t.height() as i64;
        let mut heap = BinaryHeap::new();
        dist[goal] = 0.0;
        heap.push(Node(0.0, goal as u32));
        while let Some(Node(d, c)) = heap.pop() {
            let c = c as usize;
            if d > dist[c] {
                continue;
            }
            let (cx, cy) = t.cell_xy(c);
            for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)] {
                let (nx, ny) = (cx as i64 + dx, cy as i64 + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    continue;
                }
                let nc = (ny * w + nx) as usize;
                if !t.step_ok(nc, c, cliff_walk) {
                    continue;
                }
                let nd = d + if dx != 0 && dy != 0 { std::f32::consts::SQRT_2 } else { 1.0 };
                if nd < dist[nc] {
                    dist[nc] = nd;
                    heap.push(Node(nd, nc as u32));
                }
            }
        }
        Self { dist }
    }

    pub fn distance(&self, cell: usize) -> f32 {
        self.dist.get(cell).copied().unwrap_or(UNREACHABLE)
    }
}

impl PathCache {
    pub fn field(&mut self, t: &Terrain, goal: usize, cliff_walk: bool) -> Arc<FlowField> {
        let key = (goal as u32, cliff_walk);
        if let Some(f) = self.fields.get(&key) {
            return Arc::clone(f);
        }
        if self.order.len() >= MAX_CACHED
            && let Some(old) = self.order.pop_front()
        {
            self.fields.remove(&old);
        }
        let f = Arc::new(FlowField::build(t, goal, cliff_walk));
        self.fields.insert(key, Arc::clone(&f));
        self.order.push_back(key);
        f
    }

    /// The point a ground unit at `from` should head for on its way to `to`: `to` itself when
    /// the straight line is clear, else the farthest cell centre along the flow field that
    /// can be reached in a straight line. `None` when the goal cannot be reached at all.
    pub fn waypoint(&mut self, t: &Terrain, from: Vec2, to: Vec2, cliff_walk: bool) -> Option<Vec2> {
        if t.segment_clear(from, to, cliff_walk) {
            return Some(to);
        }
        let goal = t.cell_index(to)?;
        let start = t.cell_index(from)?;
        let field = self.field(t, goal, cliff_walk);
        if !field.distance(start).is_finite() {
            return None;
        }
        let w = t.width() as i64;
        let h = t.height() as i64;
        let mut cur = start;
        let mut best = t.cell_center(start);
        for _ in 0..6 {
            let (cx, cy) = t.cell_xy(cur);
            let mut next = None;
            let mut nd = field.distance(cur);
            for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)] {
                let (nx, ny) = (cx as i64 + dx, cy as i64 + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    continue;
                }
                let nc = (ny * w + nx) as usize;
                let d = field.distance(nc);
                if d < nd && t.step_ok(cur, nc, cliff_walk) {
                    nd = d;
                    next = Some(nc);
                }
            }
            let Some(n) = next else { break };
            let c = t.cell_center(n);
            if n == goal {
                return Some(if t.segment_clear(from, to, cliff_walk) { to } else { c });
            }
            if !t.segment_clear(from, c, cliff_walk) {
                break;
            }
            best = c;
            cur = n;
        }
        Some(best)
    }
}
