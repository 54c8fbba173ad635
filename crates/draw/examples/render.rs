//! Draw netlists into a folder, as SVG and PNG:
//! `cargo run --release -p pneumo-draw --example render -- OUT_DIR [--catalogue] MODEL.json...`
//! (`--catalogue`: the symbol sheet, symbols.svg/png)
//! (the `pneumo draw` command does the same for one model, with atomic output).

use std::path::Path;

struct Fs;
impl graph::Loader for Fs {
    fn read(&self, path: &Path) -> Result<String, String> {
        std::fs::read_to_string(path).map_err(|e| e.to_string())
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((out, models)) = args.split_first() else {
        eprintln!("usage: render OUT_DIR MODEL.json...");
        std::process::exit(2);
    };
    if models.iter().any(|m| m == "--catalogue") {
        let d = draw::catalogue::catalogue().expect("catalogue");
        std::fs::write(Path::new(out).join("symbols.svg"), &d.svg).expect("write svg");
        std::fs::write(Path::new(out).join("symbols.png"), draw::png(&d.svg, 1.5).expect("png")).expect("write png");
    }
    for model in models.iter().filter(|m| *m != "--catalogue") {
        let path = Path::new(model);
        let flat = match graph::load(&Fs, path) {
            Ok(f) => f,
            Err(e) => {
                eprintln!("{model}: {e}");
                continue;
            }
        };
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let description = graph::expand::parse(&text, model).ok().and_then(|n| n.description);
        let started = std::time::Instant::now();
        match draw::diagram(&flat, description.as_deref()) {
            Ok(d) => {
                let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("diagram");
                let svg = Path::new(out).join(format!("{stem}.svg"));
                std::fs::write(&svg, &d.svg).expect("write svg");
                let png = draw::png(&d.svg, 1.5).expect("png");
                std::fs::write(Path::new(out).join(format!("{stem}.png")), png).expect("write png");
                eprintln!("{model}: {:.0} x {:.0} px in {:?}", d.width, d.height, started.elapsed());
            }
            Err(e) => eprintln!("{model}: {e}"),
        }
    }
}
