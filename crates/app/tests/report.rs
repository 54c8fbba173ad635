//! `pneumo report` pages, parsed as a browser parses them (html5ever
//! through `scraper`): the shipped meter-out circuit gives a complete page
//! whose only scripts are its own (their hashes are the ones the
//! Content-Security-Policy allows), and a hostile netlist — markup, a
//! `<script>`, a comment opener and a `</script>` in its name and
//! descriptions — renders inert: no element or attribute of it survives,
//! its text shows as text.

use pneumo_app::report::{report, ReportOptions};
use scraper::{Html, Node, Selector};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pneumo-report-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn page(model: &Path, out: &Path, cycles: u64) -> String {
    let o = ReportOptions { model: model.to_path_buf(), cycles: Some(cycles), output: out.to_path_buf(), ..Default::default() };
    let run = report(&o, &mut |_| {}).unwrap();
    assert!(run.incomplete.is_none());
    std::fs::read_to_string(out).unwrap()
}

fn select<'a>(doc: &'a Html, css: &str) -> Vec<scraper::ElementRef<'a>> {
    doc.select(&Selector::parse(css).unwrap()).collect()
}

fn sha256_base64(text: &str) -> String {
    use base64::Engine;
    use sha2::{Digest, Sha256};
    base64::engine::general_purpose::STANDARD.encode(Sha256::digest(text.as_bytes()))
}

/// The page's policy, and a check that every executable script is allowed
/// by it by hash and that nothing else may load.
fn check_policy(doc: &Html) {
    let metas = select(doc, "meta[http-equiv=\"Content-Security-Policy\"]");
    assert_eq!(metas.len(), 1, "one policy");
    let csp = metas[0].value().attr("content").unwrap();
    assert!(csp.starts_with("default-src 'none';"), "{csp}");
    assert!(!csp.contains("unsafe") && !csp.contains("http") && !csp.contains('*'), "{csp}");
    let scripts = select(doc, "script");
    let mut executable = 0;
    for s in &scripts {
        assert_eq!(s.value().attr("src"), None);
        if s.value().attr("type") == Some("application/json") {
            continue;
        }
        executable += 1;
        let text: String = s.text().collect();
        assert!(csp.contains(&format!("'sha256-{}'", sha256_base64(&text))), "a script the policy does not allow");
    }
    assert_eq!(executable, 2, "uPlot and the page's own script, nothing else");
    let styles = select(doc, "style");
    assert_eq!(styles.len(), 1);
    let style: String = styles[0].text().collect();
    assert!(csp.contains(&format!("'sha256-{}'", sha256_base64(&style))));
}

fn data_of(doc: &Html) -> Value {
    let blocks = select(doc, "script#pneumo-data");
    assert_eq!(blocks.len(), 1);
    serde_json::from_str(&blocks[0].text().collect::<String>()).expect("the data block is JSON")
}

#[test]
fn meter_out_page_has_the_diagram_the_traces_and_the_tables() {
    let dir = scratch("meter-out");
    let out = dir.join("r.html");
    let text = page(&repo().join("models/meter_out.json"), &out, 2);
    let doc = Html::parse_document(&text);
    check_policy(&doc);
    assert_eq!(select(&doc, "#circuit svg").len(), 1, "the diagram is inline");
    assert!(select(&doc, "#circuit svg text").iter().any(|t| t.text().collect::<String>() == "flow_control"));
    // the traces: one panel per quantity, units on the axes, values in them
    let data = data_of(&doc);
    let time = data["time"].as_array().unwrap();
    assert!(time.len() > 100 && time.windows(2).all(|w| w[0].as_f64() < w[1].as_f64()), "time increases");
    let panels = data["panels"].as_array().unwrap();
    let titles: Vec<&str> = panels.iter().map(|p| p["y_label"].as_str().unwrap()).collect();
    for want in ["pressure [bar (abs)]", "temperature [K]", "position [mm]", "velocity [m/s]", "mass flow [kg/s]"] {
        assert!(titles.contains(&want), "no {want} panel in {titles:?}");
    }
    let mut distinct = titles.clone();
    distinct.sort();
    distinct.dedup();
    assert_eq!(distinct.len(), titles.len(), "one panel per quantity");
    let pressure = panels.iter().find(|p| p["y_label"] == "pressure [bar (abs)]").unwrap();
    let head = pressure["series"].as_array().unwrap().iter().find(|s| s["label"] == "head.p").unwrap();
    let bar: Vec<f64> = head["values"].as_array().unwrap().iter().filter_map(Value::as_f64).collect();
    assert_eq!(bar.len(), time.len());
    let max = bar.iter().cloned().fold(f64::MIN, f64::max);
    assert!(max > 3.9 && max <= 4.001, "head pressure in bar, up to the supply's 4 bar (absolute): {max}");
    // the tables: two cycles, the polytropic index, the supply's air, the balances
    let cells = |row: &scraper::ElementRef| row.text().map(str::to_string).collect::<Vec<String>>();
    let tables = select(&doc, "#summary table");
    assert!(tables.len() >= 5, "{} tables", tables.len());
    let cycle_rows = select(&doc, "#summary table:first-of-type tbody tr");
    assert_eq!(cycle_rows.len(), 2, "two cycles");
    let total: f64 = cells(&cycle_rows[0])[5].parse().unwrap();
    assert!(total > 0.5 && total < 10.0, "a cycle of seconds: {total}");
    let headings: Vec<String> = select(&doc, "#summary h3").iter().map(|h| h.text().collect()).collect();
    for want in ["Cycle times", "Mean polytropic index", "Air consumption", "Balances"] {
        assert!(headings.iter().any(|h| h == want), "no {want} in {headings:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

const HOSTILE_NAME: &str = "<script>alert(1)</script><img src=x onerror=alert(2)>";
const HOSTILE_TEXT: &str =
    "</script><script>alert(3)</script> <!-- ]]> <svg onload=alert(4)> <a href=\"javascript:alert(5)\">x</a> & \u{1}\u{202e} </title></style>";

/// Elements the page may hold: its own markup and the diagram's.
const ALLOWED: &[&str] = &[
    "html", "head", "meta", "title", "style", "body", "header", "h1", "h2", "h3", "p", "code", "nav", "a", "section", "div", "svg", "g",
    "rect", "line", "polyline", "polygon", "circle", "path", "text", "table", "thead", "tbody", "tr", "th", "td", "noscript", "footer",
    "pre", "script", "strong", "ul", "li",
];

/// No element, attribute or comment that the page's own code does not write.
fn check_inert(doc: &Html) {
    for node in doc.tree.nodes() {
        match node.value() {
            Node::Element(e) => {
                let tag = e.name();
                assert!(ALLOWED.contains(&tag), "unexpected element <{tag}>");
                for (name, value) in e.attrs() {
                    let name = name.to_ascii_lowercase();
                    assert!(!name.starts_with("on") && name != "style" && name != "src", "attribute {name} on <{tag}>");
                    if name == "href" {
                        assert!(value.starts_with('#'), "a link out of the page: {value}");
                    }
                }
            }
            Node::Comment(c) => panic!("a comment opened by the data: {:?}", &**c),
            _ => {}
        }
    }
}

#[test]
fn a_hostile_netlist_renders_inert() {
    let dir = scratch("hostile");
    let mut netlist: Value = serde_json::from_str(&std::fs::read_to_string(repo().join("models/meter_out.json")).unwrap()).unwrap();
    netlist["name"] = Value::from(HOSTILE_NAME);
    netlist["description"] = Value::from(format!("{HOSTILE_TEXT}\n\n{HOSTILE_NAME}"));
    netlist["parameters"]["bore"]["description"] = Value::from(HOSTILE_TEXT);
    let model = dir.join("m.json");
    std::fs::write(&model, serde_json::to_string(&netlist).unwrap()).unwrap();
    let out = dir.join("r.html");
    let text = page(&model, &out, 1);
    let doc = Html::parse_document(&text);
    check_policy(&doc);
    check_inert(&doc);
    // what the netlist said is there, as text
    let h1: String = select(&doc, "h1")[0].text().collect();
    assert_eq!(h1, HOSTILE_NAME);
    let title: String = select(&doc, "title")[0].text().collect();
    assert!(title.starts_with(HOSTILE_NAME));
    let description: Vec<String> = select(&doc, "p.description").iter().map(|p| p.text().collect()).collect();
    assert_eq!(description.len(), 2);
    assert!(description[0].contains("</script><script>alert(3)</script> <!-- ]]>"), "{description:?}");
    assert!(!description[0].contains('\u{1}') && !description[0].contains('\u{202e}'), "control characters are dropped");
    // and in the diagram's text
    assert!(select(&doc, "svg title").iter().any(|t| t.text().collect::<String>().contains(HOSTILE_NAME)));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A hostile experiments manifest and data file: markup in the experiment
/// name, the data file's name and a column header. One short record
/// (the first cycle of the discrepancy example's run1.csv) and no
/// candidate effects (`"effects": []`), so only the calibration runs.
#[test]
fn a_hostile_manifest_and_data_header_render_inert() {
    let dir = scratch("hostile-manifest");
    let csv = std::fs::read_to_string(repo().join("models/examples/discrepancy/run1.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    let mut data = format!("{header},<img src=x onerror=alert(6)>\n");
    for l in lines.take(3000) {
        data.push_str(&format!("{l},0\n"));
    }
    let data_name = "<b>run<img src=x onerror=alert(7)>.csv";
    std::fs::write(dir.join(data_name), data).unwrap();
    let manifest = serde_json::json!({
        "experiments": [{
            "name": HOSTILE_NAME, "data": data_name,
            "set": { "supply.p": "4 bar", "flow_control.C": "26 L/min/bar", "controller.dwell_extended": "0.2 s", "controller.dwell_retracted": "0.2 s" },
            "columns": { "p1_Pa": "head.p", "p2_Pa": "rod.p", "x_m": "piston.x" }
        }],
        "effects": []
    });
    let e = dir.join("<i>E<b>.json");
    std::fs::write(&e, serde_json::to_string(&manifest).unwrap()).unwrap();
    let out = dir.join("r.html");
    let o = ReportOptions {
        model: repo().join("models/meter_out.json"),
        cycles: Some(1),
        output: out.clone(),
        experiments: Some(e),
        ..Default::default()
    };
    report(&o, &mut |_| {}).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    let doc = Html::parse_document(&text);
    check_policy(&doc);
    check_inert(&doc);
    assert_eq!(select(&doc, "section#discrepancy").len(), 1, "the discrepancy section is there");
    let section: String = select(&doc, "section#discrepancy")[0].text().collect();
    assert!(section.contains("<i>E<b>.json"), "the manifest's name shows as text");
    assert!(section.contains(HOSTILE_NAME), "the experiment's name shows as text in the sensor table");
    // the panels carry the experiment's name in the JSON block, never as markup
    let data = data_of(&doc);
    let fit: Vec<&Value> = data["panels"].as_array().unwrap().iter().filter(|p| p["host"] == "fit-plots").collect();
    assert_eq!(fit.len(), 3, "one panel per measured channel");
    assert!(fit.iter().all(|p| p["title"].as_str().unwrap().starts_with(HOSTILE_NAME)));
    let measured = &fit[0]["series"][0];
    assert_eq!(measured["markers"], true);
    assert!(measured["values"].as_array().unwrap().iter().filter(|v| v.is_number()).count() > 1000);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_id_with_markup_is_refused_and_nothing_is_written() {
    let dir = scratch("bad-id");
    let model = dir.join("m.json");
    std::fs::write(
        &model,
        r#"{"name": "m", "components": [{"id": "<script>x</script>", "type": "pressure_source", "params": {"p": "3 bar"}}]}"#,
    )
    .unwrap();
    let out = dir.join("r.html");
    let o = ReportOptions { model: model.clone(), output: out.clone(), ..Default::default() };
    let e = report(&o, &mut |_| {}).err().expect("refused").to_string();
    assert!(e.contains("may contain only letters"), "{e}");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_page_never_overwrites_its_model() {
    let dir = scratch("overwrite");
    let model = dir.join("m.html");
    std::fs::copy(repo().join("models/meter_out.json"), &model).unwrap();
    let before = std::fs::read(&model).unwrap();
    let o = ReportOptions { model: model.clone(), cycles: Some(1), output: model.clone(), ..Default::default() };
    assert!(report(&o, &mut |_| {}).is_err());
    assert_eq!(std::fs::read(&model).unwrap(), before);
    let _ = std::fs::remove_dir_all(&dir);
}
