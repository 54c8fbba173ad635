//! The FMI 2.0 C interface (fmi2Functions.h, fmi2FunctionTypes.h,
//! fmi2TypesPlatform.h of the FMI 2.0 standard): the types, declared from the
//! standard, and every function an importer may look up.
//!
//! Each function checks its pointers, runs the work inside `catch_unwind`
//! ([`guarded`]) and reports any error through the importer's logger.

use crate::instance::Instance;
use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

pub type Fmi2Status = c_int;
pub const FMI2_OK: Fmi2Status = 0;
pub const FMI2_WARNING: Fmi2Status = 1;
pub const FMI2_DISCARD: Fmi2Status = 2;
pub const FMI2_ERROR: Fmi2Status = 3;
pub const FMI2_FATAL: Fmi2Status = 4;

pub type Fmi2Type = c_int;
pub const FMI2_CO_SIMULATION: Fmi2Type = 1;

pub type Fmi2Boolean = c_int;
pub type Fmi2ValueReference = c_uint;
pub type Fmi2Component = *mut c_void;
pub type Fmi2ComponentEnvironment = *mut c_void;
pub type Fmi2FmuState = *mut c_void;

/// `fmi2CallbackLogger`: a printf-like function of the importer.
pub type Fmi2CallbackLogger =
    Option<unsafe extern "C" fn(Fmi2ComponentEnvironment, *const c_char, Fmi2Status, *const c_char, *const c_char, ...)>;

/// `fmi2CallbackFunctions`.
#[repr(C)]
pub struct Fmi2CallbackFunctions {
    pub logger: Fmi2CallbackLogger,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(Fmi2ComponentEnvironment, Fmi2Status)>,
    pub component_environment: Fmi2ComponentEnvironment,
}

/// What `fmi2Component` points to.
struct Component {
    name: CString,
    logger: Fmi2CallbackLogger,
    environment: Fmi2ComponentEnvironment,
    instance: Instance,
}

impl Component {
    fn log(&self, status: Fmi2Status, message: &str) {
        log_to(self.logger, self.environment, &self.name, status, message);
    }
}

fn log_to(logger: Fmi2CallbackLogger, env: Fmi2ComponentEnvironment, name: &CStr, status: Fmi2Status, message: &str) {
    let Some(logger) = logger else { return };
    // the logger formats like printf: a '%' in the message must be doubled
    let text = pneumo_app::error::one_line(message).replace('%', "%%").replace('\0', "");
    let text = CString::new(text).unwrap_or_default();
    let category = if status == FMI2_OK { c"logAll" } else { c"logStatusError" };
    // SAFETY: the importer gave this function for exactly these arguments.
    unsafe { logger(env, name.as_ptr(), status, category.as_ptr(), text.as_ptr()) };
}

/// Run `work` on the component, catching panics; an error is logged.
fn guarded(c: Fmi2Component, work: impl FnOnce(&mut Instance) -> Result<Fmi2Status, pneumo_app::AppError>) -> Fmi2Status {
    if c.is_null() {
        return FMI2_ERROR;
    }
    // SAFETY: a non-null component is one fmi2Instantiate returned and
    // fmi2FreeInstance has not freed (the standard's contract).
    let component = unsafe { &mut *(c as *mut Component) };
    match catch_unwind(AssertUnwindSafe(|| work(&mut component.instance))) {
        Ok(Ok(status)) => status,
        Ok(Err(e)) => {
            component.log(FMI2_ERROR, &e.to_string());
            FMI2_ERROR
        }
        Err(panic) => {
            let what = panic.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| panic.downcast_ref::<String>().cloned());
            component.log(FMI2_FATAL, &format!("internal error (a bug in pneumo): {}", what.unwrap_or_default()));
            FMI2_ERROR
        }
    }
}

/// A string argument, or `None` for a null pointer or invalid UTF-8.
unsafe fn text<'a>(s: *const c_char) -> Option<&'a str> {
    if s.is_null() {
        None
    } else {
        CStr::from_ptr(s).to_str().ok()
    }
}

/// The folder of a `file:` URI (`file:///tmp/x/resources`, `file:/tmp/x`), percent-decoded.
pub fn uri_to_path(uri: &str) -> Option<PathBuf> {
    let rest = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:"))?;
    let rest = rest.strip_prefix("localhost").unwrap_or(rest);
    let bytes = rest.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut k = 0;
    while k < bytes.len() {
        if bytes[k] == b'%' && k + 2 < bytes.len() {
            let hex = std::str::from_utf8(&bytes[k + 1..k + 3]).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            k += 3;
        } else {
            out.push(bytes[k]);
            k += 1;
        }
    }
    Some(PathBuf::from(String::from_utf8(out).ok()?))
}

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: *const c_char,
    fmu_type: Fmi2Type,
    guid: *const c_char,
    resource_location: *const c_char,
    functions: *const Fmi2CallbackFunctions,
    _visible: Fmi2Boolean,
    _logging_on: Fmi2Boolean,
) -> Fmi2Component {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let (logger, environment) =
            if functions.is_null() { (None, std::ptr::null_mut()) } else { ((*functions).logger, (*functions).component_environment) };
        let name = CString::new(text(instance_name).unwrap_or("pneumo")).unwrap_or_default();
        let fail = |message: String| {
            log_to(logger, environment, &name, FMI2_ERROR, &message);
            std::ptr::null_mut()
        };
        if fmu_type != FMI2_CO_SIMULATION {
            return fail("this FMU supports Co-Simulation only (FMI 2.0 Model Exchange is not offered)".into());
        }
        let Some(location) = text(resource_location) else {
            return fail("no fmuResourceLocation given: the runtime reads the netlist from the FMU's resources folder".into());
        };
        let Some(folder) = uri_to_path(location) else {
            return fail(format!("fmuResourceLocation {} is not a file: URI", graph::escape(location)));
        };
        match Instance::new(&folder, text(guid)) {
            Ok(instance) => Box::into_raw(Box::new(Component { name: name.clone(), logger, environment, instance })) as Fmi2Component,
            Err(e) => fail(e.to_string()),
        }
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// # Safety
/// `c` from fmi2Instantiate, not used afterwards.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
    if !c.is_null() {
        let _ = catch_unwind(AssertUnwindSafe(|| drop(Box::from_raw(c as *mut Component))));
    }
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Fmi2Component,
    _on: Fmi2Boolean,
    _n: usize,
    _categories: *const *const c_char,
) -> Fmi2Status {
    guarded(c, |_| Ok(FMI2_OK))
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Fmi2Component,
    _tolerance_defined: Fmi2Boolean,
    _tolerance: f64,
    start_time: f64,
    _stop_time_defined: Fmi2Boolean,
    _stop_time: f64,
) -> Fmi2Status {
    guarded(c, |i| {
        if !start_time.is_finite() {
            return Err(pneumo_app::AppError::Usage(format!("start time must be finite, got {start_time}")));
        }
        i.set_start_time(start_time);
        Ok(FMI2_OK)
    })
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
    guarded(c, |_| Ok(FMI2_OK))
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
    guarded(c, |i| i.exit_initialization().map(|_| FMI2_OK))
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
    guarded(c, |_| Ok(FMI2_OK))
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
    guarded(c, |i| {
        i.reset();
        Ok(FMI2_OK)
    })
}

/// The `n` value references at `vr` (empty for n = 0).
unsafe fn refs<'a>(vr: *const Fmi2ValueReference, n: usize) -> Result<&'a [Fmi2ValueReference], pneumo_app::AppError> {
    if n == 0 {
        Ok(&[])
    } else if vr.is_null() {
        Err(pneumo_app::AppError::Usage("null value-reference array".into()))
    } else {
        Ok(std::slice::from_raw_parts(vr, n))
    }
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(c: Fmi2Component, vr: *const Fmi2ValueReference, n: usize, value: *mut f64) -> Fmi2Status {
    guarded(c, |i| {
        let refs = refs(vr, n)?;
        if n > 0 && value.is_null() {
            return Err(pneumo_app::AppError::Usage("null value array".into()));
        }
        for (k, &r) in refs.iter().enumerate() {
            *value.add(k) = i.get(r)?;
        }
        Ok(FMI2_OK)
    })
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(c: Fmi2Component, vr: *const Fmi2ValueReference, n: usize, value: *const f64) -> Fmi2Status {
    guarded(c, |i| {
        let refs = refs(vr, n)?;
        if n > 0 && value.is_null() {
            return Err(pneumo_app::AppError::Usage("null value array".into()));
        }
        for (k, &r) in refs.iter().enumerate() {
            i.set(r, *value.add(k))?;
        }
        Ok(FMI2_OK)
    })
}

/// Integer, Boolean and String variables: this FMU has none.
unsafe fn no_such_variables(c: Fmi2Component, n: usize, kind: &str) -> Fmi2Status {
    guarded(c, |_| {
        if n == 0 {
            Ok(FMI2_OK)
        } else {
            Err(pneumo_app::AppError::Usage(format!("this FMU has no {kind} variables (all are Real)")))
        }
    })
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(c: Fmi2Component, _vr: *const Fmi2ValueReference, n: usize, _v: *mut c_int) -> Fmi2Status {
    no_such_variables(c, n, "Integer")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(c: Fmi2Component, _vr: *const Fmi2ValueReference, n: usize, _v: *const c_int) -> Fmi2Status {
    no_such_variables(c, n, "Integer")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(c: Fmi2Component, _vr: *const Fmi2ValueReference, n: usize, _v: *mut Fmi2Boolean) -> Fmi2Status {
    no_such_variables(c, n, "Boolean")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(c: Fmi2Component, _vr: *const Fmi2ValueReference, n: usize, _v: *const Fmi2Boolean) -> Fmi2Status {
    no_such_variables(c, n, "Boolean")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(c: Fmi2Component, _vr: *const Fmi2ValueReference, n: usize, _v: *mut *const c_char) -> Fmi2Status {
    no_such_variables(c, n, "String")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(c: Fmi2Component, _vr: *const Fmi2ValueReference, n: usize, _v: *const *const c_char) -> Fmi2Status {
    no_such_variables(c, n, "String")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(c: Fmi2Component, t: f64, h: f64, _no_set_prior: Fmi2Boolean) -> Fmi2Status {
    guarded(c, |i| i.do_step(t, h).map(|_| FMI2_OK))
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
    guarded(c, |_| Err(pneumo_app::AppError::Usage("fmi2CancelStep: steps are never asynchronous here".into())))
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    guarded(c, |i| {
        if state.is_null() {
            return Err(pneumo_app::AppError::Usage("null FMU-state pointer".into()));
        }
        let copy = Box::new(i.clone());
        if !(*state).is_null() {
            drop(Box::from_raw(*state as *mut Instance));
        }
        *state = Box::into_raw(copy) as Fmi2FmuState;
        Ok(FMI2_OK)
    })
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    guarded(c, |i| {
        if state.is_null() {
            return Err(pneumo_app::AppError::Usage("null FMU state".into()));
        }
        *i = (*(state as *const Instance)).clone();
        Ok(FMI2_OK)
    })
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    guarded(c, |_| {
        if !state.is_null() && !(*state).is_null() {
            drop(Box::from_raw(*state as *mut Instance));
            *state = std::ptr::null_mut();
        }
        Ok(FMI2_OK)
    })
}

fn unsupported(c: Fmi2Component, what: &str) -> Fmi2Status {
    guarded(c, |_| Err(pneumo_app::AppError::Usage(format!("{what} is not supported by this FMU"))))
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(c: Fmi2Component, _s: Fmi2FmuState, _size: *mut usize) -> Fmi2Status {
    unsupported(c, "serializing the FMU state")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(c: Fmi2Component, _s: Fmi2FmuState, _b: *mut c_char, _size: usize) -> Fmi2Status {
    unsupported(c, "serializing the FMU state")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(c: Fmi2Component, _b: *const c_char, _size: usize, _s: *mut Fmi2FmuState) -> Fmi2Status {
    unsupported(c, "serializing the FMU state")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Fmi2Component,
    _u: *const Fmi2ValueReference,
    _nu: usize,
    _z: *const Fmi2ValueReference,
    _nz: usize,
    _dv: *const f64,
    _dz: *mut f64,
) -> Fmi2Status {
    unsupported(c, "fmi2GetDirectionalDerivative")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _n: usize,
    _order: *const c_int,
    _v: *const f64,
) -> Fmi2Status {
    unsupported(c, "fmi2SetRealInputDerivatives (canInterpolateInputs is false)")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _n: usize,
    _order: *const c_int,
    _v: *mut f64,
) -> Fmi2Status {
    unsupported(c, "fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder is 0)")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(c: Fmi2Component, _kind: c_int, _v: *mut Fmi2Status) -> Fmi2Status {
    unsupported(c, "fmi2GetStatus (steps are never asynchronous)")
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(c: Fmi2Component, kind: c_int, v: *mut f64) -> Fmi2Status {
    // fmi2LastSuccessfulTime (2) is the one a master may ask for
    guarded(c, |i| {
        if kind == 2 && !v.is_null() {
            *v = i.time();
            Ok(FMI2_OK)
        } else {
            Ok(FMI2_DISCARD)
        }
    })
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(c: Fmi2Component, _kind: c_int, _v: *mut c_int) -> Fmi2Status {
    guarded(c, |_| Ok(FMI2_DISCARD))
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(c: Fmi2Component, _kind: c_int, _v: *mut Fmi2Boolean) -> Fmi2Status {
    guarded(c, |_| Ok(FMI2_DISCARD))
}

/// # Safety
/// Arguments as the FMI 2.0 standard defines them.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(c: Fmi2Component, _kind: c_int, _v: *mut *const c_char) -> Fmi2Status {
    guarded(c, |_| Ok(FMI2_DISCARD))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resource_uris_become_paths() {
        assert_eq!(uri_to_path("file:///tmp/a%20b/resources"), Some(PathBuf::from("/tmp/a b/resources")));
        assert_eq!(uri_to_path("file:/tmp/x/"), Some(PathBuf::from("/tmp/x/")));
        assert_eq!(uri_to_path("file://localhost/tmp/x"), Some(PathBuf::from("/tmp/x")));
        assert_eq!(uri_to_path("http://x/y"), None);
        assert_eq!(uri_to_path("file:///tmp/%zz"), None);
        assert_eq!(uri_to_path("file:///tmp/%2"), Some(PathBuf::from("/tmp/%2")));
    }
}
