//! Keyword arguments as `twinray render` flags: parsed by the command
//! line's own definitions (`twinray-args`), so that every flag, its checks
//! and its error messages are the command line's.

use clap::Parser;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList, PyTuple};

use twinray::JobSpec;
use twinray_args::RenderArgs;

/// `twinray render`'s flags, without the program name.
#[derive(Parser, Debug)]
#[command(name = "twinray render", no_binary_name = true)]
struct Flags {
    #[command(flatten)]
    render: RenderArgs,
}

/// One value as a flag's text: a tuple joined by commas (a size by `x`),
/// anything else as Python's `str` writes it.
fn value_text(key: &str, value: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(tuple) = value.cast::<PyTuple>() {
        let parts: Vec<String> = tuple
            .iter()
            .map(|v| value_text("", &v))
            .collect::<PyResult<_>>()?;
        // A light is ((x, y, z), (r, g, b)): position and colour.
        let sep = match key {
            "size" => "x",
            "light" if tuple.iter().all(|v| v.cast::<PyTuple>().is_ok()) => ":",
            _ => ",",
        };
        return Ok(parts.join(sep));
    }
    if value.cast::<PyList>().is_ok() {
        return Err(PyValueError::new_err(format!(
            "{key}: a list repeats a flag (light=[...]); give one value as a tuple"
        )));
    }
    value.str()?.extract()
}

/// The command line of `flags`: `key=True` is `--key`, `key=False` and
/// `key=None` are left out, a list repeats the flag, anything else is
/// `--key VALUE`. Underscores become hyphens; a trailing one is dropped
/// (`from_`, as `from` is a Python keyword).
fn command_line(flags: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
    let mut args = vec!["--print-job".to_string()];
    let Some(flags) = flags else {
        return Ok(args);
    };
    for (key, value) in flags.iter() {
        let key: String = key.extract()?;
        let name = key.trim_end_matches('_').replace('_', "-");
        let flag = format!("--{name}");
        if value.is_none() {
            continue;
        }
        if value.is_instance_of::<PyBool>() {
            if value.is_truthy()? {
                args.push(flag);
            }
            continue;
        }
        if let Ok(list) = value.cast::<PyList>() {
            for v in list.iter() {
                args.push(format!("{flag}={}", value_text(&name, &v)?));
            }
            continue;
        }
        // `--flag=VALUE`, so that a negative number is a value.
        args.push(format!("{flag}={}", value_text(&name, &value)?));
    }
    Ok(args)
}

/// The spec that keyword arguments describe, checked by the command line's
/// parser (a removed flag is refused with what replaced it).
pub fn spec_from_flags(flags: Option<&Bound<'_, PyDict>>) -> PyResult<JobSpec> {
    let args = command_line(flags)?;
    let os: Vec<std::ffi::OsString> = args.iter().map(Into::into).collect();
    twinray_args::refuse_removed(&os).map_err(PyValueError::new_err)?;
    // A scene placeholder: clap wants SCENE; the caller sets the real one.
    let mut with_scene = vec!["scene".to_string()];
    with_scene.extend(args);
    let parsed = Flags::try_parse_from(&with_scene).map_err(|e| {
        let text = e.render().to_string();
        let first = text.lines().next().unwrap_or("invalid flags").to_string();
        PyValueError::new_err(first.trim_start_matches("error: ").to_string())
    })?;
    Ok(parsed.render.spec())
}

/// Gives a job the scene's surroundings and limits (those it was loaded
/// with), refusing others: they change the scene, which is loaded already.
pub fn take_scene_settings(spec: &mut JobSpec, scene: &JobSpec) -> PyResult<()> {
    let default = JobSpec::default();
    if spec.studio != default.studio && spec.studio != scene.studio {
        return Err(PyValueError::new_err(
            "the surroundings (ground, light, background, env, up_axis) are the scene's: \
             give them to Scene.load",
        ));
    }
    if spec.limits != default.limits && spec.limits != scene.limits {
        return Err(PyValueError::new_err(
            "the file limits (max_resolution, max_vertices, max_triangles) are the scene's: \
             give them to Scene.load",
        ));
    }
    spec.studio = scene.studio.clone();
    spec.limits = scene.limits.clone();
    spec.scene = scene.scene.clone();
    Ok(())
}

/// A job renders in memory; the plan still checks an output target, so a
/// job without one gets a float file in the temporary directory, which is
/// never written.
pub fn default_output(spec: &mut JobSpec) {
    if spec.output.path.as_os_str().is_empty() {
        spec.output.path = std::env::temp_dir().join("twinray-python.pfm");
    }
}
