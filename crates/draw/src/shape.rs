//! Symbols as geometry: drawing primitives in a symbol's own coordinates
//! (px, y down, origin at the top-left of its body), the pins where lines
//! attach, and the small pieces many symbols share (flow arrows, blocked
//! ports, springs, solenoids, throttles, check valves).
//!
//! Sizes follow one module: the grid [`G`] = 10 px. Pins lie on the grid so
//! that the router's lines meet them exactly.

/// Grid pitch [px]: pins, symbol origins and lines lie on it.
pub const G: f64 = 10.0;

/// Line weights and patterns (ISO 1219-1: working lines solid, pilot and
/// signal lines dashed, enclosures chain-dotted).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stroke {
    /// Symbol outlines and working lines.
    Solid,
    /// Fine detail (springs, hatching, ruler marks).
    Thin,
    /// Pilot and signal lines.
    Dashed,
    /// Enclosures of several functions in one unit, subsystem frames.
    Chain,
    /// No outline.
    None,
}

/// Fill of a closed primitive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fill {
    None,
    Black,
    White,
    /// Light grey: the background of labels and the title block.
    Shade,
}

/// Horizontal anchoring of a text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Anchor {
    Start,
    Middle,
    End,
}

/// A drawing primitive. Text is kept raw here and escaped when written.
#[derive(Debug, Clone, PartialEq)]
pub enum Prim {
    Polyline {
        pts: Vec<(f64, f64)>,
        stroke: Stroke,
    },
    Polygon {
        pts: Vec<(f64, f64)>,
        stroke: Stroke,
        fill: Fill,
    },
    Rect {
        x: f64,
        y: f64,
        w: f64,
        h: f64,
        rx: f64,
        stroke: Stroke,
        fill: Fill,
    },
    Circle {
        cx: f64,
        cy: f64,
        r: f64,
        stroke: Stroke,
        fill: Fill,
    },
    /// A circular arc from `from` to `to` with radius `r` (SVG arc, small arc).
    Arc {
        from: (f64, f64),
        to: (f64, f64),
        r: f64,
        sweep: bool,
        stroke: Stroke,
    },
    Text {
        x: f64,
        y: f64,
        text: String,
        size: f64,
        anchor: Anchor,
        bold: bool,
        italic: bool,
    },
}

/// The side a pin's line leaves the symbol by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Dir {
    Up,
    Down,
    Left,
    Right,
}

impl Dir {
    pub fn step(self) -> (i32, i32) {
        match self {
            Dir::Up => (0, -1),
            Dir::Down => (0, 1),
            Dir::Left => (-1, 0),
            Dir::Right => (1, 0),
        }
    }
    pub fn flipped_vertically(self) -> Dir {
        match self {
            Dir::Up => Dir::Down,
            Dir::Down => Dir::Up,
            d => d,
        }
    }
}

/// What a pin carries, which decides the line drawn to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum PinKind {
    /// A working (main) pneumatic line: solid.
    Working,
    /// A pneumatic pilot (control) line: dashed.
    Pilot,
    /// A signal (electrical/logical) line: dashed, with an arrow at inputs.
    SignalIn,
    SignalOut,
    /// A mechanical link (a rod or lever outside a cylinder).
    Mechanical,
}

/// Where a line attaches to a symbol.
#[derive(Debug, Clone, PartialEq)]
pub struct Pin {
    /// Index of the member block (in the item's member list) the port belongs to.
    pub member: usize,
    /// The block's port name.
    pub port: String,
    pub x: f64,
    pub y: f64,
    pub dir: Dir,
    pub kind: PinKind,
}

/// A symbol: its body (everything drawn lies in `0..w`, `0..h`, except
/// small port names), its pins on the body's edge, and its label lines.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Shape {
    pub w: f64,
    pub h: f64,
    pub prims: Vec<Prim>,
    pub pins: Vec<Pin>,
    /// Label lines: the first is the id (drawn bold), the others key parameters.
    pub label: Vec<String>,
    /// Primitives that keep their orientation when the symbol is turned over
    /// (an adjustment arrow always points up and right): index and the y of
    /// their centre.
    pub upright: Vec<(usize, f64)>,
}

impl Shape {
    pub fn new(w: f64, h: f64) -> Self {
        Shape { w, h, ..Default::default() }
    }
    pub fn line(&mut self, x1: f64, y1: f64, x2: f64, y2: f64) {
        self.prims.push(Prim::Polyline { pts: vec![(x1, y1), (x2, y2)], stroke: Stroke::Solid });
    }
    pub fn styled_line(&mut self, pts: Vec<(f64, f64)>, stroke: Stroke) {
        self.prims.push(Prim::Polyline { pts, stroke });
    }
    pub fn poly(&mut self, pts: Vec<(f64, f64)>) {
        self.prims.push(Prim::Polyline { pts, stroke: Stroke::Solid });
    }
    pub fn rect(&mut self, x: f64, y: f64, w: f64, h: f64) {
        self.prims.push(Prim::Rect { x, y, w, h, rx: 0.0, stroke: Stroke::Solid, fill: Fill::White });
    }
    pub fn styled_rect(&mut self, x: f64, y: f64, w: f64, h: f64, stroke: Stroke, fill: Fill) {
        self.prims.push(Prim::Rect { x, y, w, h, rx: 0.0, stroke, fill });
    }
    pub fn circle(&mut self, cx: f64, cy: f64, r: f64, fill: Fill) {
        self.prims.push(Prim::Circle { cx, cy, r, stroke: Stroke::Solid, fill });
    }
    pub fn polygon(&mut self, pts: Vec<(f64, f64)>, fill: Fill) {
        self.prims.push(Prim::Polygon { pts, stroke: Stroke::Solid, fill });
    }
    pub fn text(&mut self, x: f64, y: f64, text: &str, size: f64, anchor: Anchor) {
        self.prims.push(Prim::Text { x, y, text: text.to_string(), size, anchor, bold: false, italic: false });
    }
    pub fn bold_text(&mut self, x: f64, y: f64, text: &str, size: f64, anchor: Anchor) {
        self.prims.push(Prim::Text { x, y, text: text.to_string(), size, anchor, bold: true, italic: false });
    }
    pub fn pin(&mut self, member: usize, port: &str, x: f64, y: f64, dir: Dir, kind: PinKind) {
        self.pins.push(Pin { member, port: port.to_string(), x, y, dir, kind });
    }
    /// A port name ("A/4") beside the pin's line, outside the body.
    pub fn port_name(&mut self, x: f64, y: f64, dir: Dir, name: &str) {
        let (tx, ty, anchor) = match dir {
            Dir::Up => (x + 2.0, y - 2.5, Anchor::Start),
            Dir::Down => (x + 2.0, y + 8.5, Anchor::Start),
            Dir::Left => (x - 1.0, y - 4.5, Anchor::End),
            Dir::Right => (x + 1.0, y - 4.5, Anchor::Start),
        };
        self.prims.push(Prim::Text { x: tx, y: ty, text: name.to_string(), size: 7.5, anchor, bold: false, italic: false });
    }

    /// Mirror the body top to bottom (pins and primitives); texts keep
    /// their reading direction and are re-anchored on their baseline.
    pub fn flip_vertically(&mut self) {
        let h = self.h;
        let fy = |y: f64| h - y;
        for (k, p) in self.prims.iter_mut().enumerate() {
            if let Some(&(_, cy)) = self.upright.iter().find(|(i, _)| *i == k) {
                // moved with the body, not mirrored
                let dy = h - 2.0 * cy;
                match p {
                    Prim::Polyline { pts, .. } | Prim::Polygon { pts, .. } => pts.iter_mut().for_each(|pt| pt.1 += dy),
                    Prim::Rect { y, .. } | Prim::Text { y, .. } => *y += dy,
                    Prim::Circle { cy, .. } => *cy += dy,
                    Prim::Arc { from, to, .. } => {
                        from.1 += dy;
                        to.1 += dy;
                    }
                }
                continue;
            }
            match p {
                Prim::Polyline { pts, .. } | Prim::Polygon { pts, .. } => pts.iter_mut().for_each(|pt| pt.1 = fy(pt.1)),
                Prim::Rect { y, h: rh, .. } => *y = fy(*y + *rh),
                Prim::Circle { cy, .. } => *cy = fy(*cy),
                Prim::Arc { from, to, sweep, .. } => {
                    from.1 = fy(from.1);
                    to.1 = fy(to.1);
                    *sweep = !*sweep;
                }
                // a baseline at y moves so that the text keeps its place beside the mirrored line
                Prim::Text { y, size, .. } => *y = fy(*y) + *size * 0.7,
            }
        }
        for pin in &mut self.pins {
            pin.y = fy(pin.y);
            pin.dir = pin.dir.flipped_vertically();
        }
    }

    // ---- pieces shared by several symbols ----

    /// A flow path with an arrowhead at its end (inside valve boxes).
    pub fn arrow(&mut self, from: (f64, f64), to: (f64, f64)) {
        self.line(from.0, from.1, to.0, to.1);
        self.arrowhead(from, to, 7.0, Fill::Black);
    }

    /// An arrowhead at `to`, pointing away from `from`.
    pub fn arrowhead(&mut self, from: (f64, f64), to: (f64, f64), len: f64, fill: Fill) {
        let (dx, dy) = (to.0 - from.0, to.1 - from.1);
        let n = (dx * dx + dy * dy).sqrt().max(1e-9);
        let (ux, uy) = (dx / n, dy / n);
        let (px, py) = (-uy, ux);
        let half = len * 0.38;
        let base = (to.0 - ux * len, to.1 - uy * len);
        self.polygon(vec![to, (base.0 + px * half, base.1 + py * half), (base.0 - px * half, base.1 - py * half)], fill);
    }

    /// A blocked port inside a valve box: a short stub from the box edge at
    /// `(x, y)` into the box (`inward` = +1 down, −1 up) ending in a bar.
    pub fn blocked(&mut self, x: f64, y: f64, inward: f64) {
        let len = 6.0;
        self.line(x, y, x, y + inward * len);
        self.line(x - 4.0, y + inward * len, x + 4.0, y + inward * len);
    }

    /// A spring drawn as a zigzag from `from` to `to` (n teeth of `amp` px).
    pub fn spring(&mut self, from: (f64, f64), to: (f64, f64), teeth: usize, amp: f64) {
        let (dx, dy) = (to.0 - from.0, to.1 - from.1);
        let n = (dx * dx + dy * dy).sqrt().max(1e-9);
        let (px, py) = (-dy / n, dx / n);
        let mut pts = vec![from];
        let steps = teeth * 2;
        for i in 1..steps {
            let t = i as f64 / steps as f64;
            let s = if i % 2 == 1 { amp } else { -amp };
            pts.push((from.0 + dx * t + px * s, from.1 + dy * t + py * s));
        }
        pts.push(to);
        self.prims.push(Prim::Polyline { pts, stroke: Stroke::Thin });
    }

    /// An adjustment arrow drawn diagonally through the point `(cx, cy)`.
    pub fn adjustable(&mut self, cx: f64, cy: f64, half: f64) {
        let from = (cx - half, cy + half);
        let to = (cx + half, cy - half);
        let first = self.prims.len();
        self.prims.push(Prim::Polyline { pts: vec![from, to], stroke: Stroke::Thin });
        self.arrowhead(from, to, 5.0, Fill::Black);
        for k in first..self.prims.len() {
            self.upright.push((k, cy));
        }
    }

    /// A throttle on a vertical line at x: two arcs narrowing the passage
    /// between `y0` and `y1`.
    pub fn throttle(&mut self, x: f64, y0: f64, y1: f64) {
        let r = (y1 - y0) * 0.75;
        self.prims.push(Prim::Arc { from: (x - 6.0, y0), to: (x - 6.0, y1), r, sweep: true, stroke: Stroke::Solid });
        self.prims.push(Prim::Arc { from: (x + 6.0, y0), to: (x + 6.0, y1), r, sweep: false, stroke: Stroke::Solid });
    }

    /// A check valve on a vertical line at x, its seat at `seat_y` and its
    /// ball at `ball_y`: free flow from the seat towards the ball.
    pub fn check(&mut self, x: f64, seat_y: f64, ball_y: f64, spring: bool) {
        let toward = if ball_y < seat_y { -1.0 } else { 1.0 };
        let r = 4.5;
        // the seat: a V whose apex points away from the ball
        let apex = (x, seat_y);
        let open_y = ball_y - toward * 0.5;
        self.poly(vec![(x - 7.0, open_y), apex, (x + 7.0, open_y)]);
        self.circle(x, ball_y, r, Fill::White);
        if spring {
            let from = (x, ball_y + toward * r);
            let to = (x, ball_y + toward * (r + 8.0));
            self.spring(from, to, 2, 3.0);
        }
    }

    /// A solenoid at `(x, y)` (top-left), `w` × `h`; proportional adds a
    /// second, arrowed diagonal.
    pub fn solenoid(&mut self, x: f64, y: f64, w: f64, h: f64, proportional: bool) {
        self.rect(x, y, w, h);
        self.prims.push(Prim::Polyline { pts: vec![(x, y + h), (x + w, y)], stroke: Stroke::Thin });
        if proportional {
            let from = (x + 2.0, y + h + 3.0);
            let to = (x + w + 2.0, y - 3.0);
            self.prims.push(Prim::Polyline { pts: vec![from, to], stroke: Stroke::Thin });
            self.arrowhead(from, to, 4.0, Fill::Black);
        }
    }

    /// An exhaust: an open triangle pointing away from the port at the end
    /// of a stub of `stub` px in direction `dir` from `(x, y)`.
    pub fn exhaust(&mut self, x: f64, y: f64, dir: Dir, stub: f64) {
        let (dx, dy) = dir.step();
        let (dx, dy) = (f64::from(dx), f64::from(dy));
        let end = (x + dx * stub, y + dy * stub);
        self.line(x, y, end.0, end.1);
        let (px, py) = (-dy, dx);
        let tip = (end.0 + dx * 9.0, end.1 + dy * 9.0);
        self.polygon(vec![(end.0 + px * 6.0, end.1 + py * 6.0), tip, (end.0 - px * 6.0, end.1 - py * 6.0)], Fill::White);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flipping_mirrors_pins_and_keeps_the_body() {
        let mut s = Shape::new(40.0, 60.0);
        s.pin(0, "a", 20.0, 60.0, Dir::Down, PinKind::Working);
        s.pin(0, "b", 20.0, 0.0, Dir::Up, PinKind::Working);
        s.rect(10.0, 10.0, 20.0, 10.0);
        s.flip_vertically();
        assert_eq!((s.pins[0].y, s.pins[0].dir), (0.0, Dir::Up));
        assert_eq!((s.pins[1].y, s.pins[1].dir), (60.0, Dir::Down));
        assert_eq!(s.prims[0], Prim::Rect { x: 10.0, y: 40.0, w: 20.0, h: 10.0, rx: 0.0, stroke: Stroke::Solid, fill: Fill::White });
    }
}
