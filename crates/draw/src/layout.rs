//! Placement after ISO 1219-2 habits: energy flows from the bottom to the
//! top — the supply at the bottom, valves in the middle, cylinders in the
//! top row — with one column per actuator chain and signal blocks in a
//! column to the left.
//!
//! 1. **Rows.** A working line from a pin on top of symbol S to a pin at
//!    the bottom of symbol T puts T above S. Each symbol's level is the
//!    longest chain of such constraints below it (cycles, which a valid
//!    circuit may have, are broken in a fixed order); cylinders go to the
//!    top level; a symbol with nothing below it (a breather, a silencer
//!    branch) rises to just under the lowest symbol it feeds.
//! 2. **Columns.** Each cylinder, in netlist order, claims the symbols
//!    below it; shared ones (the supply) belong to the first.
//! 3. **Alignment.** Sweeping the rows down and up, each symbol wants the
//!    median position that lines its pins up with the pins it connects to;
//!    within a row the positions closest to those wishes that keep the
//!    order and the gaps are the isotonic regression of the wishes (pool
//!    adjacent violators).
//!
//! All arithmetic is deterministic: ties are broken by index, never by
//! hashing or time.

use crate::scene::{NetKind, Role, Scene};
use crate::shape::{Dir, PinKind, G};
use crate::text::width;

/// Font sizes of the labels: the id, and the parameter lines.
pub const ID_SIZE: f64 = 10.5;
pub const PARAM_SIZE: f64 = 9.0;
pub const LABEL_LINE: f64 = 11.5;
/// Gap between a symbol and its label.
const LABEL_GAP: f64 = 6.0;
/// Smallest horizontal gap between footprints in a row.
const GAP: f64 = 3.0 * G;

/// An axis-aligned rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rect {
    pub x: f64,
    pub y: f64,
    pub w: f64,
    pub h: f64,
}

impl Rect {
    pub fn right(&self) -> f64 {
        self.x + self.w
    }
    pub fn bottom(&self) -> f64 {
        self.y + self.h
    }
    pub fn union(&self, o: &Rect) -> Rect {
        let (x, y) = (self.x.min(o.x), self.y.min(o.y));
        Rect { x, y, w: self.right().max(o.right()) - x, h: self.bottom().max(o.bottom()) - y }
    }
    pub fn grow(&self, d: f64) -> Rect {
        Rect { x: self.x - d, y: self.y - d, w: self.w + 2.0 * d, h: self.h + 2.0 * d }
    }
}

/// Where everything goes.
pub struct Layout {
    /// Top-left of each item's body.
    pub pos: Vec<(f64, f64)>,
    /// Each item's label box (absolute; zero size when it has none).
    pub label: Vec<Rect>,
    /// Subsystem frames with their titles, outermost first.
    pub frames: Vec<(Rect, String)>,
    /// Extent of the drawing (without the title block).
    pub extent: Rect,
}

/// Width and height of an item's label, and its offset from the body's top-left.
fn label_box(scene: &Scene, i: usize) -> (f64, f64, f64, f64) {
    let item = &scene.items[i];
    if item.role == Role::Control && item.shape.label.is_empty() {
        return (0.0, 0.0, 0.0, 0.0);
    }
    let w = std::iter::once(width(&item.display, ID_SIZE)).chain(item.shape.label.iter().map(|l| width(l, PARAM_SIZE))).fold(0.0, f64::max)
        + 2.0;
    let h = LABEL_LINE * (1 + item.shape.label.len()) as f64 + 2.0;
    // below the lowest pin that leaves to the right, so that its line stays clear
    let dy = item.shape.pins.iter().filter(|p| p.dir == Dir::Right).map(|p| p.y + 6.0).fold(0.0, f64::max);
    (w, h, item.shape.w + LABEL_GAP, dy)
}

/// Pool adjacent violators: positions in the given order closest (least
/// squares) to `desired` with `x[i+1] >= x[i] + sep[i]`.
pub fn pav(desired: &[f64], sep: &[f64]) -> Vec<f64> {
    weighted_pav(desired, &vec![1.0; desired.len()], sep)
}

/// [`pav`] with a weight per position (a heavier one moves less).
pub fn weighted_pav(desired: &[f64], weight: &[f64], sep: &[f64]) -> Vec<f64> {
    let n = desired.len();
    let mut offset = vec![0.0; n];
    for i in 1..n {
        offset[i] = offset[i - 1] + sep[i - 1];
    }
    // blocks of (weighted sum, weight, count) over the shifted targets, kept non-decreasing in mean
    let mut blocks: Vec<(f64, f64, usize)> = Vec::with_capacity(n);
    for i in 0..n {
        blocks.push(((desired[i] - offset[i]) * weight[i], weight[i], 1));
        while blocks.len() >= 2 {
            let (s1, w1, c1) = blocks[blocks.len() - 1];
            let (s0, w0, c0) = blocks[blocks.len() - 2];
            if s0 / w0 > s1 / w1 {
                blocks.pop();
                let last = blocks.len() - 1;
                blocks[last] = (s0 + s1, w0 + w1, c0 + c1);
            } else {
                break;
            }
        }
    }
    let mut out = Vec::with_capacity(n);
    for (s, w, c) in blocks {
        for _ in 0..c {
            out.push(s / w + offset[out.len()]);
        }
    }
    out
}

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    Some(if v.len() % 2 == 1 { v[m] } else { (v[m - 1] + v[m]) / 2.0 })
}

fn snap(x: f64) -> f64 {
    (x / G).round() * G
}

/// Rows of the items taking part in the pneumatic layout (row 0 at the top).
fn rows(scene: &Scene) -> Vec<Option<usize>> {
    let n = scene.items.len();
    let in_rows: Vec<bool> = scene.items.iter().map(|it| it.role != Role::Control).collect();
    // below[i]: items directly below i; above[i]: directly above
    let mut above: Vec<Vec<usize>> = vec![Vec::new(); n];
    for net in &scene.nets {
        if net.kind != NetKind::Pneumatic || net.exhaust.is_some() {
            continue;
        }
        let working = |dir: Dir| -> Vec<usize> {
            net.pins
                .iter()
                .filter(|p| {
                    let pin = &scene.items[p.item].shape.pins[p.pin];
                    pin.kind == PinKind::Working && pin.dir == dir
                })
                .map(|p| p.item)
                .collect()
        };
        for &lower in &working(Dir::Up) {
            for &upper in &working(Dir::Down) {
                if lower != upper && in_rows[lower] && in_rows[upper] && !above[lower].contains(&upper) {
                    above[lower].push(upper);
                }
            }
        }
    }
    // break cycles: depth-first from each item in index order, dropping edges back to the stack
    let mut state = vec![0u8; n]; // 0 new, 1 on stack, 2 done
    let mut kept: Vec<Vec<usize>> = vec![Vec::new(); n];
    for start in 0..n {
        if state[start] != 0 {
            continue;
        }
        let mut stack: Vec<(usize, usize)> = vec![(start, 0)];
        state[start] = 1;
        while let Some(&mut (v, ref mut k)) = stack.last_mut() {
            if *k < above[v].len() {
                let w = above[v][*k];
                *k += 1;
                match state[w] {
                    0 => {
                        kept[v].push(w);
                        state[w] = 1;
                        stack.push((w, 0));
                    }
                    2 => kept[v].push(w),
                    _ => {} // back edge: a cycle, dropped
                }
            } else {
                state[v] = 2;
                stack.pop();
            }
        }
    }
    let mut below: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (v, ups) in kept.iter().enumerate() {
        for &u in ups {
            below[u].push(v);
        }
    }
    // longest path from the bottom, by repeated relaxation in a topological order
    let mut indegree: Vec<usize> = below.iter().map(Vec::len).collect();
    let mut ready: std::collections::VecDeque<usize> = (0..n).filter(|&i| indegree[i] == 0).collect();
    let mut level = vec![0usize; n];
    while let Some(v) = ready.pop_front() {
        for &u in &kept[v] {
            level[u] = level[u].max(level[v] + 1);
            indegree[u] -= 1;
            if indegree[u] == 0 {
                ready.push_back(u);
            }
        }
    }
    let top = (0..n).filter(|&i| in_rows[i]).map(|i| level[i]).max().unwrap_or(0);
    for (i, item) in scene.items.iter().enumerate() {
        if item.role == Role::Actuator {
            level[i] = top;
        }
    }
    // symbols with nothing below them rise to just under what they feed
    for _ in 0..n {
        let mut changed = false;
        for i in 0..n {
            if !in_rows[i] || item_is_actuator(scene, i) || !below[i].is_empty() || kept[i].is_empty() {
                continue;
            }
            let want = kept[i].iter().map(|&u| level[u]).min().unwrap_or(1).saturating_sub(1);
            if want > level[i] {
                level[i] = want;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let top = (0..n).filter(|&i| in_rows[i]).map(|i| level[i]).max().unwrap_or(0);
    (0..n).map(|i| in_rows[i].then(|| top - level[i])).collect()
}

fn item_is_actuator(scene: &Scene, i: usize) -> bool {
    scene.items[i].role == Role::Actuator
}

/// Column (actuator chain) of every item in rows.
fn chains(scene: &Scene, row: &[Option<usize>]) -> Vec<usize> {
    let n = scene.items.len();
    let unset = usize::MAX;
    let mut chain = vec![unset; n];
    // neighbours through working and mechanical lines
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for net in scene.nets.iter().filter(|n| n.kind != NetKind::Signal && n.exhaust.is_none()) {
        for a in &net.pins {
            for b in &net.pins {
                if a.item != b.item && !adj[a.item].contains(&b.item) {
                    adj[a.item].push(b.item);
                }
            }
        }
    }
    let actuators: Vec<usize> = (0..n).filter(|&i| item_is_actuator(scene, i)).collect();
    for (c, &a) in actuators.iter().enumerate() {
        // the actuator claims what lies below it along its lines
        let mut queue = std::collections::VecDeque::from([a]);
        if chain[a] == unset {
            chain[a] = c;
        }
        while let Some(v) = queue.pop_front() {
            for &w in &adj[v] {
                if chain[w] == unset && row[w].is_some() && row[w] > row[v] {
                    chain[w] = c;
                    queue.push_back(w);
                }
            }
        }
    }
    // the rest joins a neighbour's column
    for _ in 0..n {
        let mut changed = false;
        for i in 0..n {
            if chain[i] == unset {
                if let Some(c) = adj[i].iter().map(|&j| chain[j]).filter(|&c| c != unset).min() {
                    chain[i] = c;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    let last = actuators.len();
    chain.iter().map(|&c| if c == unset { last } else { c }).collect()
}

/// Signal blocks that serve a single actuator chain, when there are
/// several: (row, chain, the symbol they drive) of each.
fn local_controllers(scene: &Scene, row: &[Option<usize>], chain: &[usize]) -> Vec<Option<(usize, usize, usize)>> {
    let n = scene.items.len();
    let chains: std::collections::BTreeSet<usize> = (0..n).filter(|&i| row[i].is_some()).map(|i| chain[i]).collect();
    let mut out = vec![None; n];
    if chains.len() < 2 {
        return out;
    }
    for c in (0..n).filter(|&i| row[i].is_none()) {
        let mut neighbours = std::collections::BTreeSet::new();
        let mut driven = None;
        for net in scene.nets.iter().filter(|net| net.kind == NetKind::Signal) {
            let Some(own) = net.pins.iter().find(|p| p.item == c) else { continue };
            let output = scene.items[c].shape.pins[own.pin].kind == PinKind::SignalOut;
            for p in net.pins.iter().filter(|p| p.item != c) {
                if row[p.item].is_none() {
                    continue;
                }
                neighbours.insert(chain[p.item]);
                if output && driven.is_none() {
                    driven = Some(p.item);
                }
            }
        }
        if let (Some(d), 1) = (driven, neighbours.len()) {
            if let Some(r) = row[d] {
                out[c] = Some((r, chain[d], d));
            }
        }
    }
    out
}

/// Place every item.
pub fn place(scene: &Scene) -> Layout {
    let n = scene.items.len();
    let labels: Vec<(f64, f64, f64, f64)> = (0..n).map(|i| label_box(scene, i)).collect();
    let foot_w: Vec<f64> = (0..n)
        .map(|i| {
            let (lw, _, dx, _) = labels[i];
            if lw > 0.0 {
                (dx + lw).max(scene.items[i].shape.w)
            } else {
                scene.items[i].shape.w
            }
        })
        .collect();
    let foot_h: Vec<f64> = (0..n).map(|i| (labels[i].3 + labels[i].1).max(scene.items[i].shape.h)).collect();
    let mut row = rows(scene);
    let mut chain = chains(scene, &row);
    let nrows = row.iter().flatten().max().map(|r| r + 1).unwrap_or(0);
    // with several actuator chains, a signal block that serves one chain only
    // stands in that chain's column, left of the symbol it drives
    let local = local_controllers(scene, &row, &chain);
    for (c, l) in local.iter().enumerate() {
        if let Some((r, k, _)) = *l {
            row[c] = Some(r);
            chain[c] = k;
        }
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); nrows];
    for (i, r) in row.iter().enumerate() {
        if let Some(r) = *r {
            members[r].push(i);
        }
    }

    // ---- initial x: columns side by side ----
    let ncols = chain.iter().copied().max().map(|c| c + 1).unwrap_or(0);
    let mut col_w = vec![0.0f64; ncols];
    for r in &members {
        for (c, w) in col_w.iter_mut().enumerate() {
            let sum: f64 = r.iter().filter(|&&i| chain[i] == c).map(|&i| foot_w[i] + GAP).sum();
            *w = w.max(sum);
        }
    }
    let mut x = vec![0.0f64; n];
    let mut col_x = 0.0;
    for (c, &cw) in col_w.iter().enumerate() {
        for r in &members {
            let mut cx = col_x;
            for &i in r.iter().filter(|&&i| chain[i] == c) {
                x[i] = cx;
                cx += foot_w[i] + GAP;
            }
        }
        col_x += cw + GAP;
    }

    // ---- alignment sweeps ----
    // (own pin x, other item, other pin x) for pins joined by a line
    let mut links: Vec<Vec<(f64, usize, f64)>> = vec![Vec::new(); n];
    // lines passing a row without a pin in it: obstacles the row's symbols keep clear of
    let mut passing: Vec<Vec<usize>> = vec![Vec::new(); nrows];
    let lines: Vec<usize> =
        (0..scene.nets.len()).filter(|&k| scene.nets[k].kind != NetKind::Signal && scene.nets[k].exhaust.is_none()).collect();
    for &k in &lines {
        let net = &scene.nets[k];
        for a in &net.pins {
            for b in &net.pins {
                if a.item != b.item && row[a.item].is_some() && row[b.item].is_some() && row[a.item] != row[b.item] {
                    let pa = &scene.items[a.item].shape.pins[a.pin];
                    let pb = &scene.items[b.item].shape.pins[b.pin];
                    links[a.item].push((pa.x, b.item, pb.x));
                }
            }
        }
        let rs: Vec<usize> = net.pins.iter().filter_map(|p| row[p.item]).collect();
        if let (Some(&lo), Some(&hi)) = (rs.iter().min(), rs.iter().max()) {
            for (r, pass) in passing.iter_mut().enumerate().take(hi).skip(lo + 1) {
                if !rs.contains(&r) {
                    pass.push(k);
                }
            }
        }
    }
    let pin_x = |x: &[f64], p: &crate::scene::PinRef| x[p.item] + scene.items[p.item].shape.pins[p.pin].x;
    // 13 sweeps: the last one runs top down, so that the supply ends under the valves it feeds
    for sweep in 0..13 {
        let order: Vec<usize> = if sweep % 2 == 0 { (0..nrows).collect() } else { (0..nrows).rev().collect() };
        for r in order {
            // (wished left edge, footprint width, item or None for a passing line, where its lines come from)
            let mut wish: Vec<(f64, f64, Option<usize>, f64)> = members[r]
                .iter()
                .filter(|&&i| local[i].is_none())
                .map(|&i| {
                    let mut cands: Vec<f64> = links[i].iter().map(|&(own, j, other)| x[j] + other - own).collect();
                    let mut sources: Vec<f64> = links[i].iter().map(|&(_, j, other)| x[j] + other).collect();
                    let left = median(&mut cands).unwrap_or(x[i]);
                    (left, foot_w[i], Some(i), median(&mut sources).unwrap_or(left + foot_w[i] / 2.0))
                })
                .collect();
            // a local signal block just left of what it drives
            let drivers: Vec<(f64, f64, Option<usize>, f64)> = members[r]
                .iter()
                .filter_map(|&c| local[c].map(|(_, _, driven)| (c, driven)))
                .map(|(c, driven)| {
                    let key = wish.iter().find(|w| w.2 == Some(driven)).map(|w| w.3).unwrap_or(x[driven]);
                    (x[driven] - foot_w[c] - GAP, foot_w[c], Some(c), key - 0.5)
                })
                .collect();
            wish.extend(drivers);
            for &k in &passing[r] {
                let mut xs: Vec<f64> =
                    scene.nets[k].pins.iter().filter(|p| row[p.item].is_some() && local[p.item].is_none()).map(|p| pin_x(&x, p)).collect();
                if let Some(m) = median(&mut xs) {
                    wish.push((m, 0.0, None, m));
                }
            }
            // barycentre order: by where the lines come from
            wish.sort_by(|a, b| {
                let key = |w: &(f64, f64, Option<usize>, f64)| (w.3, w.2.map(|i| chain[i]).unwrap_or(0), w.2.unwrap_or(usize::MAX));
                let (ka, kb) = (key(a), key(b));
                ka.0.total_cmp(&kb.0).then(ka.1.cmp(&kb.1)).then(ka.2.cmp(&kb.2))
            });
            let desired: Vec<f64> = wish.iter().map(|w| w.0).collect();
            let sep: Vec<f64> = wish.iter().map(|w| w.1 + GAP).collect();
            // a passing line is placed by the rows it joins: it hardly moves
            let weight: Vec<f64> = wish.iter().map(|w| if w.2.is_some() { 1.0 } else { 8.0 }).collect();
            let placed = weighted_pav(&desired, &weight, &sep);
            // snap to the grid keeping the gaps
            let mut last_right = f64::NEG_INFINITY;
            for (k, pos) in placed.into_iter().enumerate() {
                let mut xi = snap(pos);
                while xi < last_right + GAP - 0.5 {
                    xi += G;
                }
                last_right = xi + wish[k].1;
                if let Some(i) = wish[k].2 {
                    x[i] = xi;
                }
            }
            members[r] = wish.iter().filter_map(|w| w.2).collect();
        }
    }

    // ---- rows top to bottom, with channels sized by the lines crossing them ----
    let mut y = vec![0.0f64; n];
    let mut cursor = 0.0;
    for (r, in_row) in members.iter().enumerate() {
        let body_h = in_row.iter().map(|&i| scene.items[i].shape.h).fold(0.0, f64::max);
        let mut bottom = cursor;
        for &i in in_row {
            y[i] = snap(cursor + (body_h - scene.items[i].shape.h) / 2.0);
            bottom = f64::max(bottom, y[i] + foot_h[i]);
        }
        // lines crossing the channel under this row, counted per column (columns do not share tracks)
        let mut per_chain: std::collections::BTreeMap<usize, usize> = std::collections::BTreeMap::new();
        for net in scene.nets.iter().filter(|net| net.exhaust.is_none()) {
            let rs: Vec<usize> = net.pins.iter().filter_map(|p| row[p.item]).collect();
            if rs.iter().any(|&q| q <= r) && rs.iter().any(|&q| q > r) {
                let chains: std::collections::BTreeSet<usize> =
                    net.pins.iter().filter(|p| row[p.item].is_some()).map(|p| chain[p.item]).collect();
                for c in chains {
                    *per_chain.entry(c).or_default() += 1;
                }
            }
        }
        let crossing = per_chain.values().copied().max().unwrap_or(0);
        cursor = snap(bottom + (crossing as f64 + 4.0) * G);
    }

    // ---- the control column, left of the circuit ----
    let controls: Vec<usize> = (0..n).filter(|&i| row[i].is_none()).collect();
    if !controls.is_empty() {
        let left = (0..n).filter(|&i| row[i].is_some()).map(|i| x[i]).fold(f64::INFINITY, f64::min);
        let left = if left.is_finite() { left } else { 0.0 };
        let signal_nets = scene.nets.iter().filter(|n| n.kind == NetKind::Signal).count();
        let right_edge = snap(left - (6.0 + signal_nets.min(12) as f64) * G);
        let mut wish_y: Vec<f64> = vec![f64::NAN; n];
        for _ in 0..4 {
            for &c in &controls {
                let mut cands = Vec::new();
                for net in &scene.nets {
                    if !net.pins.iter().any(|p| p.item == c) {
                        continue;
                    }
                    for p in net.pins.iter().filter(|p| p.item != c) {
                        let pin = &scene.items[p.item].shape.pins[p.pin];
                        if row[p.item].is_some() {
                            cands.push(y[p.item] + pin.y - scene.items[c].shape.h / 2.0);
                        } else if wish_y[p.item].is_finite() {
                            cands.push(wish_y[p.item]);
                        }
                    }
                }
                if let Some(m) = median(&mut cands) {
                    wish_y[c] = m;
                }
            }
        }
        let mut order: Vec<(f64, usize)> = controls.iter().map(|&c| (if wish_y[c].is_finite() { wish_y[c] } else { 0.0 }, c)).collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let desired: Vec<f64> = order.iter().map(|o| o.0).collect();
        let sep: Vec<f64> = order.iter().map(|o| foot_h[o.1] + 3.0 * G).collect();
        let mut last_bottom = f64::NEG_INFINITY;
        for (k, pos) in pav(&desired, &sep).into_iter().enumerate() {
            let c = order[k].1;
            let mut yc = snap(pos);
            while yc < last_bottom + 3.0 * G - 0.5 {
                yc += G;
            }
            y[c] = yc;
            last_bottom = yc + foot_h[c];
            x[c] = snap(right_edge - scene.items[c].shape.w);
        }
    }

    // ---- labels, frames, extent; then shift everything to a margin ----
    let mut label: Vec<Rect> = (0..n)
        .map(|i| {
            let (w, h, dx, dy) = labels[i];
            Rect { x: x[i] + dx, y: y[i] + dy, w, h }
        })
        .collect();
    let footprint = |i: usize| Rect { x: x[i], y: y[i], w: foot_w[i], h: foot_h[i] };
    // (frame, group path, title); deepest groups first, so that outer frames include inner ones
    let mut frames: Vec<(Rect, String, String)> = Vec::new();
    let mut groups: Vec<&crate::scene::Group> = scene.groups.iter().collect();
    groups.sort_by_key(|g| std::cmp::Reverse(g.path.matches('.').count()));
    for g in groups {
        let prefix = format!("{}.", g.path);
        let inside: Vec<usize> = (0..n).filter(|&i| scene.items[i].group == g.path || scene.items[i].group.starts_with(&prefix)).collect();
        let Some(first) = inside.first() else { continue };
        let mut r = inside.iter().fold(footprint(*first), |acc, &i| acc.union(&footprint(i)));
        for (inner, _, _) in frames.iter().filter(|(_, path, _)| path.starts_with(&prefix)) {
            r = r.union(inner);
        }
        // room for the title above the contents
        let r = Rect { x: r.x - G, y: r.y - 2.5 * G, w: r.w + 2.0 * G, h: r.h + 3.5 * G };
        let title = if g.file.is_empty() { g.path.clone() } else { format!("{} — {}", g.path, g.file) };
        frames.push((r, g.path.clone(), title));
    }
    let mut extent = (0..n).fold(None::<Rect>, |acc, i| {
        let r = footprint(i);
        Some(acc.map_or(r, |a| a.union(&r)))
    });
    for (r, _, _) in &frames {
        extent = Some(extent.map_or(*r, |a| a.union(r)));
    }
    let extent = extent.unwrap_or_default().grow(4.0 * G);
    let (dx, dy) = (snap(-extent.x), snap(-extent.y));
    let pos: Vec<(f64, f64)> = (0..n).map(|i| (x[i] + dx, y[i] + dy)).collect();
    for l in &mut label {
        l.x += dx;
        l.y += dy;
    }
    let mut frames: Vec<(Rect, String)> = frames.into_iter().map(|(r, _, t)| (Rect { x: r.x + dx, y: r.y + dy, ..r }, t)).collect();
    frames.reverse();
    Layout { pos, label, frames, extent: Rect { x: 0.0, y: 0.0, w: extent.w, h: extent.h } }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pav_keeps_order_and_gaps_and_is_least_squares() {
        // no conflict: positions as wished
        assert_eq!(pav(&[0.0, 100.0], &[10.0, 10.0]), vec![0.0, 100.0]);
        // two items wishing the same place split around it
        assert_eq!(pav(&[50.0, 50.0], &[20.0, 20.0]), vec![40.0, 60.0]);
        // a chain of three: the middle one pushes both neighbours
        let x = pav(&[0.0, 5.0, 10.0], &[10.0, 10.0, 10.0]);
        assert_eq!(x, vec![-5.0, 5.0, 15.0]);
        for w in x.windows(2) {
            assert!(w[1] - w[0] >= 10.0 - 1e-9);
        }
    }
}
