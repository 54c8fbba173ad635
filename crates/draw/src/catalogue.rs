//! The symbol sheet: the symbol of every registered block type, in the
//! order of the block catalogue (docs/blocks.md), each with example
//! parameters — the legend a reader of a pneumo diagram needs — followed by
//! cylinders as a circuit shows them (a piston with its chambers, spring,
//! load, cushion, switches and sensor).

use crate::shape::{Anchor, Shape, G};
use crate::symbols::{self, Ctx, Member};
use crate::DrawError;
use blocks::params::{ParamKind, Params, Range};
use blocks::registry::BlockType;
use blocks::RawValue;
use std::collections::BTreeSet;
use std::fmt::Write;

/// Example values for a block type's required parameters (and for the
/// few whose defaults would not draw anything worth seeing).
pub fn sample(ty: &BlockType) -> Vec<(&'static str, RawValue)> {
    let text = |s: &str| RawValue::Text(s.to_string());
    match ty.name {
        "sequencer" => {
            return vec![
                ("inputs", text("start, a1")),
                ("outputs", text("A")),
                ("transitions", RawValue::List(vec![text("0 -> 1 : start"), text("1 -> 0 : a1")])),
                ("actions", RawValue::List(vec![text("A : 1")])),
            ]
        }
        "cushion" => {
            return vec![
                ("stroke", text("200 mm")),
                ("cushion_length", text("20 mm")),
                ("C", text("80 L/min/bar")),
                ("b", RawValue::Number(0.3)),
                ("C_needle", text("3 L/min/bar")),
            ]
        }
        "schedule" => return vec![("times", text("0.5 s, 1.5 s")), ("values", text("1, 0"))],
        _ => {}
    }
    ty.params
        .iter()
        .filter(|p| p.default.is_none())
        .map(|p| {
            let value = match (p.kind, p.range) {
                (_, Range::OpenUnit) => RawValue::Number(0.3),
                (ParamKind::Quantity(_), _) if !p.display_unit.is_empty() => text(&format!("20 {}", p.display_unit)),
                (ParamKind::Words, _) => text("a"),
                _ => RawValue::Number(1.0),
            };
            (p.name, value)
        })
        .collect()
}

/// The symbol of block type `ty` with [`sample`] parameters, every port
/// drawn as a pin; `None` when the type has no symbol of its own.
pub fn symbol_of(ty: &'static BlockType) -> Result<Option<Shape>, DrawError> {
    let raw = sample(ty);
    let block =
        blocks::registry::build(ty.name, raw.iter().map(|(k, v)| (*k, v))).map_err(|e| DrawError::Internal(format!("{}: {e}", ty.name)))?;
    let params =
        Params::from_raw(ty.params, raw.iter().map(|(k, v)| (*k, v))).map_err(|e| DrawError::Internal(format!("{}: {e}", ty.name)))?;
    let member = Member { id: ty.name, ty, params: &params, ports: block.ports() };
    let used: BTreeSet<(usize, String)> = block.ports().iter().map(|p| (0, p.name.to_string())).collect();
    let members = [member];
    Ok(symbols::block_symbol(&Ctx { members: &members, used: &used, flip: false }))
}

/// A cylinder as circuits show it, from blocks with these (type, parameters).
fn cylinder(parts: &[(&'static str, Vec<(&'static str, RawValue)>)]) -> Result<Shape, DrawError> {
    let mut built = Vec::new();
    for (k, (name, raw)) in parts.iter().enumerate() {
        let ty = blocks::registry::block_type(name).map_err(|e| DrawError::Internal(e.to_string()))?;
        let block =
            blocks::registry::build(name, raw.iter().map(|(k, v)| (*k, v))).map_err(|e| DrawError::Internal(format!("{name}: {e}")))?;
        let params =
            Params::from_raw(ty.params, raw.iter().map(|(k, v)| (*k, v))).map_err(|e| DrawError::Internal(format!("{name}: {e}")))?;
        built.push((k, ty, block, params));
    }
    let ids: Vec<String> = built.iter().map(|(k, ty, _, _)| format!("{}{k}", ty.name)).collect();
    let members: Vec<Member> =
        built.iter().zip(&ids).map(|((_, ty, block, params), id)| Member { id, ty, params, ports: block.ports() }).collect();
    let mut used = BTreeSet::new();
    for (k, m) in members.iter().enumerate() {
        match m.ty.name {
            "limit_switch" => {
                used.insert((k, "on".to_string()));
            }
            "cushion" => {
                used.insert((k, "line".to_string()));
            }
            _ => {}
        }
    }
    Ok(symbols::actuators::cylinder(&Ctx { members: &members, used: &used, flip: false }))
}

/// The sheet as an SVG document.
pub fn catalogue() -> Result<crate::Diagram, DrawError> {
    let text = |s: &str| RawValue::Text(s.to_string());
    let mut cells: Vec<(String, Shape)> = Vec::new();
    for ty in blocks::registry::TYPES {
        let shape = symbol_of(ty)?.ok_or_else(|| DrawError::Internal(format!("no symbol for {}", ty.name)))?;
        cells.push((ty.name.to_string(), shape));
    }
    let piston = |stroke: &str| ("piston", vec![("mass", text("1 kg")), ("stroke", text(stroke))]);
    let head = ("chamber", vec![("dead_volume", text("5 cm3")), ("bore", text("32 mm"))]);
    let rod = (
        "chamber",
        vec![("dead_volume", text("5 cm3")), ("bore", text("32 mm")), ("rod_diameter", text("12 mm")), ("orientation", text("retract"))],
    );
    cells.push(("cylinder, double-acting".into(), cylinder(&[piston("200 mm"), head.clone(), rod.clone(), ("friction", vec![])])?));
    cells.push((
        "cylinder, single-acting".into(),
        cylinder(&[piston("100 mm"), head.clone(), ("spring", vec![("stiffness", text("0.2 N/mm")), ("preload", text("30 N"))])])?,
    ));
    cells.push((
        "cylinder with cushion, load, switches".into(),
        cylinder(&[
            piston("200 mm"),
            head,
            rod,
            ("cushion", sample(blocks::registry::block_type("cushion").map_err(|e| DrawError::Internal(e.to_string()))?)),
            ("load", vec![("mass", text("2 kg"))]),
            ("limit_switch", vec![("position", text("1 mm")), ("actuated", text("below"))]),
            ("limit_switch", vec![("position", text("199 mm"))]),
            ("position_sensor", vec![]),
        ])?,
    ));

    // a grid of cells: symbol on top, name and parameters below
    let cols = 5;
    let cell_w = 34.0 * G;
    let heights: Vec<f64> = cells.iter().map(|(_, s)| s.h + 4.0 * G + 12.0 * (s.label.len() as f64)).collect();
    let rows = cells.len().div_ceil(cols);
    let row_h: Vec<f64> =
        (0..rows).map(|r| heights[r * cols..((r + 1) * cols).min(cells.len())].iter().fold(0.0f64, |a, &b| a.max(b)) + 3.0 * G).collect();
    let width = cols as f64 * cell_w + 4.0 * G;
    let height = row_h.iter().sum::<f64>() + 8.0 * G;
    let mut out = String::new();
    let _ = writeln!(out, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{0}" height="{1}" viewBox="0 0 {0} {1}" font-family="{2}">"#,
        crate::svg::num(width),
        crate::svg::num(height),
        crate::svg::attr(crate::text::FAMILY)
    );
    let _ = writeln!(out, "<title>pneumo symbol sheet</title>");
    let _ = writeln!(out, r##"<rect x="0" y="0" width="{}" height="{}" fill="#fff"/>"##, crate::svg::num(width), crate::svg::num(height));
    let mut sheet = Shape::default();
    sheet.bold_text(2.0 * G, 3.0 * G, "pneumo symbols (ISO 1219-1 style), one per block type", 13.0, Anchor::Start);
    crate::render::prims(&mut out, &sheet.prims, "#000");
    let mut y = 6.0 * G;
    for (r, h) in row_h.iter().enumerate() {
        for c in 0..cols {
            let Some((name, shape)) = cells.get(r * cols + c) else { break };
            let x = 2.0 * G + c as f64 * cell_w;
            let sx = x + ((cell_w - 2.0 * G - shape.w) / 2.0).max(0.0);
            let _ = writeln!(out, r#"<g transform="translate({} {})">"#, crate::svg::num(sx), crate::svg::num(y + G));
            crate::render::prims(&mut out, &shape.prims, "#000");
            let _ = writeln!(out, "</g>");
            let mut t = Shape::default();
            let ty = y + shape.h + 3.0 * G;
            t.bold_text(x + cell_w / 2.0 - G, ty, name, 10.0, Anchor::Middle);
            for (k, line) in shape.label.iter().enumerate() {
                t.text(x + cell_w / 2.0 - G, ty + 12.0 * (k as f64 + 1.0), &crate::svg::shorten(line, 46), 8.5, Anchor::Middle);
            }
            crate::render::prims(&mut out, &t.prims, "#1a1a1a");
        }
        y += h;
    }
    let _ = writeln!(out, "</svg>");
    Ok(crate::Diagram { svg: out, width, height, placed: Vec::new(), nets: Vec::new() })
}
