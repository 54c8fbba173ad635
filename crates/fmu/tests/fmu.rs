//! The FMU end to end, as an importer sees it: export a shipped netlist with
//! `pneumo_app::fmu::export`, unpack it, load `binaries/linux64/<id>.so`
//! with `dlopen`, call the FMI 2.0 functions, step 1 ms, and compare the
//! outputs at the communication points with the run `pneumo simulate` makes
//! (`pneumo_app::run`). Also: errors come back as `fmi2Error` with a
//! one-line message through the logger, never a crash.
//!
//! Needs the runtime library beside the test executable
//! (`target/release/deps/libpneumo_fmu.so`): `cargo test` builds it with
//! this package. A second importer, a plain C host (tests/c_host/host.c),
//! is compiled with the system's C compiler and runs the FMU in its own
//! process.

use libloading::{Library, Symbol};
use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

type Component = *mut c_void;
type Vr = c_uint;

#[repr(C)]
struct Callbacks {
    logger: Option<unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char)>,
    allocate: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    free: Option<unsafe extern "C" fn(*mut c_void)>,
    step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    env: *mut c_void,
}

static LOG: Mutex<Vec<(c_int, String)>> = Mutex::new(Vec::new());

/// A logger that takes the message as it is (the runtime escapes '%', so
/// no format arguments follow; a non-variadic function reads it the same
/// way on x86-64).
unsafe extern "C" fn logger(_env: *mut c_void, _name: *const c_char, status: c_int, _category: *const c_char, message: *const c_char) {
    let text = CStr::from_ptr(message).to_string_lossy().replace("%%", "%");
    LOG.lock().unwrap().push((status, text));
}

fn models() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

/// The runtime library of this very build: `cargo test` compiles the crate's
/// cdylib into the test executable's own folder (`target/release/deps`); only
/// `cargo build` copies it up to `target/release`, so a copy there may be
/// stale or, on a fresh clone, missing.
fn runtime() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let beside = exe.parent().unwrap().join(pneumo_app::fmu::RUNTIME_LIBRARY);
    assert!(beside.is_file(), "cargo test did not build the runtime library at {}", beside.display());
    beside
}

/// A fresh scratch folder.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pneumo-fmu-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Export `model` into `dir`, unpack it there; return the unpacked folder.
fn export_and_unpack(model: &Path, dir: &Path) -> PathBuf {
    let fmu = dir.join("model.fmu");
    pneumo_app::fmu::export(model, &fmu, &runtime()).unwrap_or_else(|e| panic!("export: {e}"));
    let mut archive = zip::ZipArchive::new(std::fs::File::open(&fmu).unwrap()).unwrap();
    let unpacked = dir.join("unpacked");
    archive.extract(&unpacked).unwrap();
    unpacked
}

/// The FMI functions of one loaded FMU.
struct Fmu {
    lib: Library,
    description: String,
    id: String,
    unpacked: PathBuf,
}

impl Fmu {
    fn load(unpacked: &Path) -> Fmu {
        let description = std::fs::read_to_string(unpacked.join("modelDescription.xml")).unwrap();
        let id = attribute(&description, "modelIdentifier");
        let lib = unsafe { Library::new(unpacked.join("binaries/linux64").join(format!("{id}.so"))).unwrap() };
        Fmu { lib, description, id, unpacked: unpacked.to_path_buf() }
    }

    fn vr(&self, name: &str) -> Vr {
        let at = self.description.find(&format!("name=\"{name}\"")).unwrap_or_else(|| panic!("no variable {name}"));
        attribute(&self.description[at..], "valueReference").parse().unwrap()
    }

    fn instantiate(&self, guid: &str) -> Component {
        let uri = CString::new(format!("file://{}", self.unpacked.join("resources").display())).unwrap();
        let name = CString::new(self.id.clone()).unwrap();
        let guid = CString::new(guid).unwrap();
        let callbacks = Box::leak(Box::new(Callbacks {
            logger: Some(logger),
            allocate: None,
            free: None,
            step_finished: None,
            env: std::ptr::null_mut(),
        }));
        unsafe {
            let f: Symbol<
                unsafe extern "C" fn(*const c_char, c_int, *const c_char, *const c_char, *const Callbacks, c_int, c_int) -> Component,
            > = self.lib.get(b"fmi2Instantiate").unwrap();
            f(name.as_ptr(), 1, guid.as_ptr(), uri.as_ptr(), callbacks, 0, 0)
        }
    }

    fn call(&self, symbol: &str, c: Component) -> c_int {
        unsafe {
            let f: Symbol<unsafe extern "C" fn(Component) -> c_int> = self.lib.get(symbol.as_bytes()).unwrap();
            f(c)
        }
    }

    fn start(&self) -> Component {
        let c = self.instantiate(&attribute(&self.description, "guid"));
        assert!(!c.is_null(), "fmi2Instantiate failed: {:?}", LOG.lock().unwrap());
        unsafe {
            let setup: Symbol<unsafe extern "C" fn(Component, c_int, f64, f64, c_int, f64) -> c_int> =
                self.lib.get(b"fmi2SetupExperiment").unwrap();
            assert_eq!(setup(c, 0, 0.0, 0.0, 0, 0.0), 0);
        }
        assert_eq!(self.call("fmi2EnterInitializationMode", c), 0);
        c
    }

    fn set(&self, c: Component, vr: Vr, value: f64) -> c_int {
        unsafe {
            let f: Symbol<unsafe extern "C" fn(Component, *const Vr, usize, *const f64) -> c_int> = self.lib.get(b"fmi2SetReal").unwrap();
            f(c, &vr, 1, &value)
        }
    }

    fn get(&self, c: Component, vr: Vr) -> f64 {
        let mut value = f64::NAN;
        unsafe {
            let f: Symbol<unsafe extern "C" fn(Component, *const Vr, usize, *mut f64) -> c_int> = self.lib.get(b"fmi2GetReal").unwrap();
            assert_eq!(f(c, &vr, 1, &mut value), 0, "fmi2GetReal: {:?}", LOG.lock().unwrap());
        }
        value
    }

    fn step(&self, c: Component, t: f64, h: f64) -> c_int {
        unsafe {
            let f: Symbol<unsafe extern "C" fn(Component, f64, f64, c_int) -> c_int> = self.lib.get(b"fmi2DoStep").unwrap();
            f(c, t, h, 1)
        }
    }

    fn free(&self, c: Component) {
        unsafe {
            let f: Symbol<unsafe extern "C" fn(Component)> = self.lib.get(b"fmi2FreeInstance").unwrap();
            f(c)
        }
    }
}

fn attribute(xml: &str, name: &str) -> String {
    let at = xml.find(&format!(" {name}=\"")).unwrap_or_else(|| panic!("no attribute {name}")) + name.len() + 3;
    xml[at..at + xml[at..].find('"').unwrap()].to_string()
}

/// `pneumo simulate`'s run of `model` for `t_end`: (t, value in SI) of `column`.
fn simulate(model: &Path, column: &str, t_end: f64) -> Vec<(f64, f64)> {
    let (flat, _) = pneumo_app::load::netlist_with_files(model, &[]).unwrap();
    let spec = pneumo_app::run::RunSpec { t_end: Some(t_end), ..Default::default() };
    let run = pneumo_app::run::run_flat(flat, &spec).unwrap_or_else(|e| panic!("{e}"));
    run.result.series(column).unwrap_or_else(|| panic!("no column {column}: {:?}", run.result.columns))
}

/// Step the FMU 1 ms at a time to `t_end`; largest |FMU output − reference|
/// (both in mm) at the reference's samples, and how many were compared.
fn compare(fmu: &Fmu, c: Component, output: &str, reference: &[(f64, f64)], t_end: f64) -> (f64, usize) {
    let vr = fmu.vr(output);
    let h = 1e-3;
    let (mut worst, mut compared) = (0.0f64, 0);
    let steps = (t_end / h).round() as usize;
    for k in 0..steps {
        assert_eq!(fmu.step(c, k as f64 * h, h), 0, "fmi2DoStep at {} s: {:?}", k as f64 * h, LOG.lock().unwrap());
        let t = (k + 1) as f64 * h;
        if let Some(&(_, x)) = reference.iter().find(|(tr, _)| (tr - t).abs() < 1e-9) {
            worst = worst.max((fmu.get(c, vr) - x * 1e3).abs());
            compared += 1;
        }
    }
    (worst, compared)
}

#[test]
fn meter_out_fmu_reproduces_simulate_within_a_tenth_of_a_millimetre() {
    let dir = scratch("meter_out");
    let fmu = Fmu::load(&export_and_unpack(&models().join("meter_out.json"), &dir));
    assert!(fmu.description.contains("<Unit name=\"mm\"><BaseUnit m=\"1\" factor=\"0.001\"/></Unit>"), "{}", fmu.description);
    let c = fmu.start();
    // a top-level parameter, set before initialization, with its unit
    assert_eq!(fmu.get(c, fmu.vr("stroke")), 450.0);
    assert_eq!(fmu.call("fmi2ExitInitializationMode", c), 0);
    assert_eq!(fmu.get(c, fmu.vr("x")), 0.0, "the piston starts retracted");
    let reference = simulate(&models().join("meter_out.json"), "piston.x", 3.0);
    let (worst, compared) = compare(&fmu, c, "x", &reference, 3.0);
    assert!(compared > 2900, "{compared} points compared");
    // issue 26 asks for 1 mm; the two integrate the same equations to rtol 1e-4
    assert!(worst < 0.1, "largest difference in x: {worst} mm");
    assert!(fmu.get(c, fmu.vr("air")) > 0.0);
    // a parameter after initialization is refused with a message, not a crash
    LOG.lock().unwrap().clear();
    assert_eq!(fmu.set(c, fmu.vr("stroke"), 400.0), 3);
    assert!(
        LOG.lock().unwrap().iter().any(|(s, m)| *s == 3 && m.contains("\"stroke\" is fixed after initialization")),
        "{:?}",
        LOG.lock().unwrap()
    );
    fmu.free(c);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn position_control_driven_through_its_input_matches_simulate_and_errors_are_statuses() {
    // the valve command `u` as a constant input: the PID's connection removed, so
    // `pneumo simulate` reads the input's start value where the FMU reads the input
    let dir = scratch("position_control");
    let mut netlist: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(models().join("position_control.json")).unwrap()).unwrap();
    netlist["connections"].as_array_mut().unwrap().retain(|c| c.get("to").and_then(|t| t.as_str()) != Some("valve.u"));
    netlist["interface"]["inputs"]["u"]["start"] = serde_json::json!(0.3);
    netlist["simulation"]["outputs"] = serde_json::json!(["sensor.x"]);
    // the shipped model uses the built-in cylinder; refer to it as a file here so
    // that the test also checks a sub-circuit file travels inside the FMU
    for c in netlist["components"].as_array_mut().unwrap() {
        if c["type"] == "cylinder" {
            let c = c.as_object_mut().unwrap();
            c.insert("type".into(), serde_json::json!("subsystem"));
            c.insert("file".into(), serde_json::json!("lib/cylinder.json"));
        }
    }
    std::fs::create_dir_all(dir.join("lib")).unwrap();
    std::fs::copy(models().join("lib/cylinder.json"), dir.join("lib/cylinder.json")).unwrap();
    let model = dir.join("position_control.json");
    std::fs::write(&model, serde_json::to_string_pretty(&netlist).unwrap()).unwrap();

    let fmu = Fmu::load(&export_and_unpack(&model, &dir));
    assert!(fmu.unpacked.join("resources/lib/cylinder.json").exists(), "the subsystem travels with the netlist");
    let c = fmu.start();
    assert_eq!(fmu.get(c, fmu.vr("u")), 0.3);
    assert_eq!(fmu.call("fmi2ExitInitializationMode", c), 0);
    let reference = simulate(&model, "sensor.x", 0.5);
    let (worst, compared) = compare(&fmu, c, "x_sensor", &reference, 0.5);
    assert!(compared > 490, "{compared} points compared");
    assert!(worst < 0.1, "largest difference in x_sensor: {worst} mm");

    // errors: an output set, a step from the wrong time, a wrong GUID
    LOG.lock().unwrap().clear();
    assert_eq!(fmu.set(c, fmu.vr("x"), 1.0), 3);
    assert_eq!(fmu.step(c, 0.1, 1e-3), 3);
    let wrong = fmu.instantiate("{00000000-0000-0000-0000-000000000000}");
    assert!(wrong.is_null());
    let log = LOG.lock().unwrap().clone();
    assert_eq!(log.len(), 3, "{log:?}");
    assert!(log.iter().all(|(s, m)| *s == 3 && !m.contains('\n')), "{log:?}");
    assert!(log[0].1.contains("\"x\" is an output"), "{log:?}");
    assert!(log[1].1.contains("step from t = 0.1 s, but the model is at t = 0.5"), "{log:?}");
    assert!(log[2].1.contains("GUID"), "{log:?}");
    // the instance still works after the refused calls
    let x = fmu.get(c, fmu.vr("x"));
    assert_eq!(fmu.set(c, fmu.vr("u"), -0.3), 0);
    assert_eq!(fmu.step(c, 0.5, 0.2), 0);
    assert!(fmu.get(c, fmu.vr("x")) < x - 1.0, "u = -0.3 retracts: x from {x} to {} mm", fmu.get(c, fmu.vr("x")));
    fmu.free(c);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A second importer (issue 26): the plain C host of tests/c_host/host.c,
/// compiled with the system's C compiler (the one Rust links with), loads
/// the exported meter-out FMU in its own process, steps it 1 ms at a time
/// for 3 s and prints the piston position; it must agree with `pneumo
/// simulate` as the in-process importer above does.
#[test]
fn a_c_host_runs_the_meter_out_fmu_and_reproduces_simulate() {
    use std::process::Command;
    let dir = scratch("c_host");
    let host = dir.join("host");
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/c_host/host.c");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    match Command::new(&cc).arg("-O2").arg("-o").arg(&host).arg(&source).arg("-ldl").status() {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            eprintln!("skipped: no C compiler `{cc}` on PATH ({e}); set CC to run the C host test");
            return;
        }
        Err(e) => panic!("running {cc}: {e}"),
        Ok(status) => assert!(status.success(), "{cc} could not compile {}", source.display()),
    }
    let unpacked = export_and_unpack(&models().join("meter_out.json"), &dir);
    let fmu = Fmu::load(&unpacked);
    let library = unpacked.join("binaries/linux64").join(format!("{}.so", fmu.id));
    let uri = format!("file://{}", unpacked.join("resources").display());
    let guid = attribute(&fmu.description, "guid");
    let vr = fmu.vr("x").to_string();
    let out =
        Command::new(&host).arg(&library).args([uri.as_str(), fmu.id.as_str(), guid.as_str(), "3", "0.001", vr.as_str()]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "the C host failed: {stderr}");
    let printed: Vec<(f64, f64)> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|line| {
            let mut fields = line.split_whitespace().map(|f| f.parse::<f64>().unwrap());
            (fields.next().unwrap(), fields.next().unwrap())
        })
        .collect();
    assert_eq!(printed.len(), 3000, "one line per 1 ms step");
    let reference = simulate(&models().join("meter_out.json"), "piston.x", 3.0);
    let (mut worst, mut compared) = (0.0f64, 0);
    for (t, x_mm) in &printed {
        if let Some(&(_, x)) = reference.iter().find(|(tr, _)| (tr - t).abs() < 1e-6) {
            worst = worst.max((x_mm - x * 1e3).abs());
            compared += 1;
        }
    }
    assert!(compared > 2900, "{compared} points compared");
    // the piston travels the whole 450 mm stroke in these 3 s, so a host that
    // stepped nothing or read the wrong variable fails by hundreds of mm
    assert!(printed.iter().any(|(_, x)| *x > 400.0), "the piston never extended in the C host's run");
    assert!(worst < 0.1, "largest difference in x between the C host and simulate: {worst} mm");
    std::fs::remove_dir_all(&dir).unwrap();
}
