//! Orthogonal lines on the grid: a maze router (A* over grid points with
//! the direction of arrival in the state, so that bends cost).
//!
//! Symbol bodies are walls; pins are left through their side; labels and
//! the neighbourhood of symbols cost extra; a line may cross another
//! (drawn without a dot, as ISO 1219 does) but never run along it or turn
//! on it, so that two lines are never mistaken for one. A net with several
//! pins grows as a tree: each further pin is routed to the nearest point of
//! what is already drawn, and a point where three or more branches meet is
//! a junction (a dot). Nets are routed in a fixed order (working lines
//! first, shortest first), so the result is deterministic. A search that
//! finds no way within its budget falls back to an L-shaped line.

use crate::layout::Rect;
use crate::shape::{Dir, G};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Cost of one grid step, of a bend, of crossing another line, of a step
/// next to a symbol and of a step through a label.
const STEP: u32 = 10;
const BEND: u32 = 40;
const CROSS: u32 = 30;
const NEAR: u32 = 6;
const LABEL: u32 = 150;
/// Most states one search may expand.
const BUDGET: usize = 200_000;
/// Most states all the searches of one drawing may expand (a few seconds);
/// the lines of a drawing that needs more are drawn L-shaped.
const TOTAL_BUDGET: usize = 6_000_000;
/// Largest area searched (grid points): a line that finds no way within
/// [`WINDOW_MARGIN`] grid steps of its pins searches the whole grid up to
/// this size, and beyond it is drawn L-shaped.
const MAX_SEARCH_POINTS: usize = 1_500_000;
/// How far around its pins and tree a line first looks for its way [grid steps].
const WINDOW_MARGIN: i32 = 24;

/// A pin to connect: its grid point and the way out of its symbol.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Terminal {
    pub at: (i32, i32),
    pub dir: Dir,
    /// Index of the style the branch to this pin is drawn in.
    pub style: u8,
}

/// A grid point.
pub type Point = (i32, i32);
/// A unit segment between two grid points, with the style it is drawn in.
pub type Segment = (Point, Point, u8);

/// A routed net: unit segments between grid points, each with its style,
/// and the junction points.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Routed {
    pub segments: Vec<Segment>,
    pub junctions: Vec<(i32, i32)>,
}

/// The points and unit segments of a net drawn so far.
#[derive(Default)]
struct Tree {
    points: Vec<(i32, i32)>,
    set: std::collections::BTreeSet<(i32, i32)>,
    segments: std::collections::BTreeSet<((i32, i32), (i32, i32))>,
}

/// Grid occupancy.
pub struct Grid {
    w: i32,
    h: i32,
    wall: Vec<bool>,
    cost: Vec<u32>,
    /// Net using the point in a horizontal / vertical run (+1; 0 = free).
    horizontal: Vec<u32>,
    vertical: Vec<u32>,
    /// Net that turns, ends or branches at the point, or reserved it (+1).
    node: Vec<u32>,
    /// States expanded so far by all searches (bounded by [`TOTAL_BUDGET`]).
    expanded: std::cell::Cell<usize>,
}

impl Grid {
    /// A grid covering `w` × `h` px.
    pub fn new(w: f64, h: f64) -> Grid {
        let (w, h) = ((w / G).ceil() as i32 + 1, (h / G).ceil() as i32 + 1);
        let size = (w.max(1) * h.max(1)) as usize;
        Grid {
            w,
            h,
            wall: vec![false; size],
            cost: vec![0; size],
            horizontal: vec![0; size],
            vertical: vec![0; size],
            node: vec![0; size],
            expanded: std::cell::Cell::new(0),
        }
    }

    fn index(&self, p: (i32, i32)) -> Option<usize> {
        (p.0 >= 0 && p.1 >= 0 && p.0 < self.w && p.1 < self.h).then(|| (p.1 * self.w + p.0) as usize)
    }

    /// Grid points inside `r` (edges included), clipped to the grid.
    fn points(&self, r: &Rect) -> impl Iterator<Item = (i32, i32)> {
        let (x0, y0) = ((r.x / G).ceil() as i32, (r.y / G).ceil() as i32);
        let (x1, y1) = ((r.right() / G).floor() as i32, (r.bottom() / G).floor() as i32);
        let (w, h) = (self.w, self.h);
        (y0.max(0)..=y1.min(h - 1)).flat_map(move |y| (x0.max(0)..=x1.min(w - 1)).map(move |x| (x, y)))
    }

    /// A symbol body: a wall, with a costly ring around it.
    pub fn wall(&mut self, r: &Rect) {
        for p in self.points(&r.grow(G)).collect::<Vec<_>>() {
            if let Some(i) = self.index(p) {
                self.cost[i] += NEAR;
            }
        }
        for p in self.points(r).collect::<Vec<_>>() {
            if let Some(i) = self.index(p) {
                self.wall[i] = true;
            }
        }
    }

    /// A label: lines may cross it, at a price.
    pub fn soft(&mut self, r: &Rect) {
        for p in self.points(r).collect::<Vec<_>>() {
            if let Some(i) = self.index(p) {
                self.cost[i] = self.cost[i].max(LABEL);
            }
        }
    }

    /// A point no line may use (an exhaust mark).
    pub fn block(&mut self, p: (i32, i32)) {
        if let Some(i) = self.index(p) {
            self.wall[i] = true;
        }
    }

    /// Reserve a pin's point and its first step out for net `net`.
    pub fn reserve(&mut self, t: &Terminal, net: usize) {
        for p in [t.at, step(t.at, t.dir)] {
            if let Some(i) = self.index(p) {
                self.node[i] = net as u32 + 1;
            }
        }
    }

    /// Route net `net` through its terminals.
    pub fn route(&mut self, net: usize, terminals: &[Terminal]) -> Routed {
        let tag = net as u32 + 1;
        let mut out = Routed::default();
        let Some(first) = terminals.first() else { return out };
        // the tree: points of the net, with the runs through them
        let mut tree = Tree::default();
        let start_out = step(first.at, first.dir);
        self.add(&mut out, &mut tree, &[first.at, start_out], tag, first.style);
        let mut rest: Vec<&Terminal> = terminals[1..].iter().collect();
        while !rest.is_empty() {
            // the pin nearest to what is drawn goes next
            let (k, _) = rest
                .iter()
                .enumerate()
                .map(|(k, t)| (k, tree.points.iter().map(|p| (p.0 - t.at.0).abs() + (p.1 - t.at.1).abs()).min().unwrap_or(0)))
                .min_by_key(|&(k, d)| (d, k))
                .unwrap_or((0, 0));
            let t = rest.remove(k);
            let out_point = step(t.at, t.dir);
            if tree.set.contains(&out_point) {
                self.add(&mut out, &mut tree, &[t.at, out_point], tag, t.style);
                continue;
            }
            let path = self.search(out_point, t.dir, &tree.points, tag).unwrap_or_else(|| l_path(out_point, &tree.points));
            let mut full = vec![t.at];
            full.extend(path);
            self.add(&mut out, &mut tree, &full, tag, t.style);
        }
        // junctions: points where three or more unit segments of the net meet
        let mut degree: std::collections::BTreeMap<(i32, i32), usize> = std::collections::BTreeMap::new();
        for (a, b, _) in &out.segments {
            *degree.entry(*a).or_default() += 1;
            *degree.entry(*b).or_default() += 1;
        }
        out.junctions = degree.into_iter().filter(|&(_, d)| d >= 3).map(|(p, _)| p).collect();
        out
    }

    /// Add a path (consecutive points, each one step apart or collinear) to the net.
    fn add(&mut self, out: &mut Routed, tree: &mut Tree, path: &[(i32, i32)], tag: u32, style: u8) {
        for w in path.windows(2) {
            let (a, b) = (w[0], w[1]);
            for (p, q) in unit_steps(a, b) {
                let horizontal = p.1 == q.1;
                for r in [p, q] {
                    if let Some(i) = self.index(r) {
                        if horizontal {
                            self.horizontal[i] = tag;
                        } else {
                            self.vertical[i] = tag;
                        }
                    }
                    if tree.set.insert(r) {
                        tree.points.push(r);
                    }
                }
                if tree.segments.insert(if p < q { (p, q) } else { (q, p) }) {
                    out.segments.push((p, q, style));
                }
            }
        }
        // ends and bends belong to this net alone
        for (k, &p) in path.iter().enumerate() {
            let bend = k == 0 || k == path.len() - 1 || {
                let (a, c) = (path[k - 1], path[k + 1]);
                (a.0 == p.0) != (p.0 == c.0)
            };
            if bend {
                if let Some(i) = self.index(p) {
                    self.node[i] = tag;
                }
            }
        }
    }

    /// A* from `start` (left in direction `dir`) to any point of `tree`.
    fn search(&self, start: (i32, i32), dir: Dir, tree: &[(i32, i32)], tag: u32) -> Option<Vec<(i32, i32)>> {
        // first within a window around the pin and the tree, then (if small enough) the whole grid
        let (mut x0, mut y0, mut x1, mut y1) = (start.0, start.1, start.0, start.1);
        for &(x, y) in tree {
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
        let m = WINDOW_MARGIN;
        let window = ((x0 - m).max(0), (y0 - m).max(0), (x1 + m).min(self.w - 1), (y1 + m).min(self.h - 1));
        let whole = (0, 0, self.w - 1, self.h - 1);
        let points = |w: (i32, i32, i32, i32)| ((w.2 - w.0 + 1) * (w.3 - w.1 + 1)) as usize;
        if points(window) > MAX_SEARCH_POINTS {
            return None; // a line across a very large drawing: an L-shaped one will do
        }
        self.search_in(start, dir, tree, tag, window).or_else(|| {
            (window != whole && self.wall.len() <= MAX_SEARCH_POINTS).then(|| self.search_in(start, dir, tree, tag, whole)).flatten()
        })
    }

    /// A* inside the window (x0, y0, x1, y1), grid points inclusive.
    fn search_in(&self, start: (i32, i32), dir: Dir, tree: &[(i32, i32)], tag: u32, win: (i32, i32, i32, i32)) -> Option<Vec<(i32, i32)>> {
        let (wx0, wy0, wx1, wy1) = win;
        let ww = wx1 - wx0 + 1;
        let local = |p: (i32, i32)| -> Option<usize> {
            (p.0 >= wx0 && p.1 >= wy0 && p.0 <= wx1 && p.1 <= wy1).then(|| ((p.1 - wy0) * ww + (p.0 - wx0)) as usize)
        };
        let si = local(start)?;
        self.index(start)?;
        let dirs = [Dir::Up, Dir::Down, Dir::Left, Dir::Right];
        let d_index = |d: Dir| dirs.iter().position(|&x| x == d).unwrap_or(0);
        let n = (ww * (wy1 - wy0 + 1)) as usize;
        let mut best = vec![u32::MAX; n * 4];
        let mut from: Vec<u32> = vec![u32::MAX; n * 4];
        let mut target = vec![false; n];
        // a point of the tree where no other line runs (not on a symbol's edge, not a crossing)
        for &p in tree {
            if let (Some(i), Some(l)) = (self.index(p), local(p)) {
                let other = |v: u32| v != 0 && v != tag;
                target[l] = !self.wall[i] && !other(self.horizontal[i]) && !other(self.vertical[i]);
            }
        }
        // heuristic: distance to the nearest tree point's bounding box
        let (mut bx0, mut by0, mut bx1, mut by1) = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
        for &(x, y) in tree {
            bx0 = bx0.min(x);
            by0 = by0.min(y);
            bx1 = bx1.max(x);
            by1 = by1.max(y);
        }
        let h = |p: (i32, i32)| -> u32 {
            let dx = (bx0 - p.0).max(0).max(p.0 - bx1);
            let dy = (by0 - p.1).max(0).max(p.1 - by1);
            (dx + dy) as u32 * STEP
        };
        let mut heap = BinaryHeap::new();
        let s = si * 4 + d_index(dir);
        best[s] = 0;
        let mut seq = 0u64;
        heap.push(Reverse((h(start), seq, s as u32)));
        let mut expanded = 0usize;
        while let Some(Reverse((_, _, state))) = heap.pop() {
            let state = state as usize;
            let (lcell, d) = (state / 4, dirs[state % 4]);
            let p = ((lcell as i32) % ww + wx0, (lcell as i32) / ww + wy0);
            let cell = self.index(p)?;
            let g = best[state];
            if target[lcell] {
                self.expanded.set(self.expanded.get() + expanded);
                return Some(if state == s { vec![start] } else { unwind(state, &from, ww, (wx0, wy0)) });
            }
            expanded += 1;
            if expanded > BUDGET || self.expanded.get() + expanded > TOTAL_BUDGET {
                self.expanded.set(self.expanded.get() + expanded);
                return None;
            }
            for nd in dirs {
                // no U-turns
                if nd.step() == (-d.step().0, -d.step().1) {
                    continue;
                }
                let q = step(p, nd);
                let (Some(qi), Some(ql)) = (self.index(q), local(q)) else { continue };
                let turning = nd != d;
                // never turn on another net's line, nor pass another's bend or pin
                if turning
                    && ((self.horizontal[cell] != 0 && self.horizontal[cell] != tag)
                        || (self.vertical[cell] != 0 && self.vertical[cell] != tag)
                        || (self.node[cell] != 0 && self.node[cell] != tag))
                {
                    continue;
                }
                if self.wall[qi] {
                    continue;
                }
                let horizontal = matches!(nd, Dir::Left | Dir::Right);
                let (same, other) = if horizontal { (&self.horizontal, &self.vertical) } else { (&self.vertical, &self.horizontal) };
                if same[qi] != 0 && same[qi] != tag {
                    continue;
                }
                if self.node[qi] != 0 && self.node[qi] != tag {
                    continue;
                }
                let mut c = STEP + self.cost[qi];
                if turning {
                    c += BEND;
                }
                if other[qi] != 0 && other[qi] != tag {
                    c += CROSS;
                }
                let next = ql * 4 + d_index(nd);
                let ng = g.saturating_add(c);
                if ng < best[next] {
                    best[next] = ng;
                    from[next] = state as u32;
                    seq += 1;
                    heap.push(Reverse((ng + h(q), seq, next as u32)));
                }
            }
        }
        self.expanded.set(self.expanded.get() + expanded);
        None
    }

    /// States expanded by all searches so far.
    pub fn effort(&self) -> usize {
        self.expanded.get()
    }
}

/// The path to `state` (a window-local state index), from the search's start.
fn unwind(mut state: usize, from: &[u32], ww: i32, origin: (i32, i32)) -> Vec<(i32, i32)> {
    let mut path = Vec::new();
    loop {
        let cell = (state / 4) as i32;
        path.push((cell % ww + origin.0, cell / ww + origin.1));
        let prev = from[state];
        if prev == u32::MAX {
            break;
        }
        state = prev as usize;
    }
    path.reverse();
    path
}

fn step(p: (i32, i32), d: Dir) -> (i32, i32) {
    let (dx, dy) = d.step();
    (p.0 + dx, p.1 + dy)
}

/// The unit steps between two points on one grid line.
fn unit_steps(a: (i32, i32), b: (i32, i32)) -> Vec<((i32, i32), (i32, i32))> {
    let mut out = Vec::new();
    if a.0 != b.0 && a.1 != b.1 {
        // not on one line: go horizontally, then vertically
        let corner = (b.0, a.1);
        out.extend(unit_steps(a, corner));
        out.extend(unit_steps(corner, b));
        return out;
    }
    let (dx, dy) = ((b.0 - a.0).signum(), (b.1 - a.1).signum());
    let mut p = a;
    while p != b {
        let q = (p.0 + dx, p.1 + dy);
        out.push((p, q));
        p = q;
    }
    out
}

/// The fallback: from `start` to the nearest tree point, across then along.
fn l_path(start: (i32, i32), tree: &[(i32, i32)]) -> Vec<(i32, i32)> {
    let target = tree.iter().copied().min_by_key(|p| ((p.0 - start.0).abs() + (p.1 - start.1).abs(), p.0, p.1)).unwrap_or(start);
    vec![start, (target.0, start.1), target]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term(x: i32, y: i32, dir: Dir) -> Terminal {
        Terminal { at: (x, y), dir, style: 0 }
    }

    #[test]
    fn a_straight_line_between_facing_pins() {
        let mut g = Grid::new(200.0, 200.0);
        let r = g.route(0, &[term(5, 15, Dir::Up), term(5, 3, Dir::Down)]);
        assert_eq!(r.segments.len(), 12);
        assert!(r.segments.iter().all(|(a, b, _)| a.0 == 5 && b.0 == 5));
        assert!(r.junctions.is_empty());
    }

    #[test]
    fn lines_go_around_walls_and_never_share_a_run() {
        let mut g = Grid::new(300.0, 300.0);
        g.wall(&Rect { x: 30.0, y: 90.0, w: 100.0, h: 40.0 });
        let a = g.route(0, &[term(8, 20, Dir::Up), term(8, 3, Dir::Down)]);
        for (p, q, _) in &a.segments {
            for pt in [p, q] {
                assert!(!(pt.0 >= 3 && pt.0 <= 13 && pt.1 >= 9 && pt.1 <= 13), "through the wall at {pt:?}");
            }
        }
        let b = g.route(1, &[term(9, 20, Dir::Up), term(9, 3, Dir::Down)]);
        for s in &b.segments {
            assert!(!a.segments.iter().any(|t| (t.0, t.1) == (s.0, s.1) || (t.0, t.1) == (s.1, s.0)), "shared run {s:?}");
        }
    }

    #[test]
    fn a_three_pin_net_has_one_junction() {
        let mut g = Grid::new(300.0, 300.0);
        let r = g.route(0, &[term(10, 20, Dir::Up), term(5, 5, Dir::Down), term(15, 5, Dir::Down)]);
        assert_eq!(r.junctions.len(), 1, "{r:?}");
    }
}
