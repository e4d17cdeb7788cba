//! The native part of the `twinray` Python package: a scene loaded once,
//! jobs planned against it, and renders handed back as numpy arrays. The
//! Python side (`python/twinray/`) wraps the arrays in a `Result` and holds
//! the data set generator and the Ray driver.

mod args;
mod render;
mod rig;

use std::path::PathBuf;
use std::sync::Arc;

use numpy::IntoPyArray;
use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use twinray::job::{Level, Loaded, Message, Plan};
use twinray::JobSpec;

/// A library error as the Python exception a caller expects: a bad value
/// or file is `ValueError`, an unreadable or unwritable file `OSError`, a
/// cancelled render `KeyboardInterrupt`.
pub(crate) fn py_error(e: twinray::Error) -> PyErr {
    match e {
        twinray::Error::Cancelled => PyKeyboardInterrupt::new_err("render cancelled"),
        twinray::Error::Io { .. } => PyOSError::new_err(e.to_string()),
        other => PyValueError::new_err(other.to_string()),
    }
}

/// Python's `json.loads` of `text`: the spec as the dict `--print-job` prints.
fn json_to_py<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// Python's `json.dumps` of `value`.
fn py_to_json(value: &Bound<'_, PyAny>) -> PyResult<String> {
    value
        .py()
        .import("json")?
        .call_method1("dumps", (value,))?
        .extract()
}

/// Sends a stage's warnings to Python's `warnings` module; returns every
/// message as (level, text).
fn messages(py: Python<'_>, list: &[Message]) -> PyResult<Vec<(String, String)>> {
    let warnings = py.import("warnings")?;
    let mut out = Vec::new();
    for m in list {
        let level = match m.level {
            Level::Info => "info",
            Level::Note => "note",
            Level::Warning => {
                warnings.call_method1("warn", (format!("twinray: {}", m.text),))?;
                "warning"
            }
        };
        out.push((level.to_string(), m.text.clone()));
    }
    Ok(out)
}

/// A scene file read once, ready for any number of jobs.
///
/// `Scene.load(path, **flags)` reads an NFF, OBJ, glTF, STL or PLY file.
/// The flags are `twinray render`'s that change the scene itself, with
/// underscores: `ground=True`, `lights=[...]`, `background=(r, g, b)`,
/// `env="sky.hdr"`, `up_axis="z"`, `max_triangles=...`. Every `Job` made
/// from the scene shares it and its hierarchy (built by the first plan).
#[pyclass(frozen, module = "twinray._native")]
struct Scene {
    loaded: Arc<Loaded>,
    /// The spec the scene was loaded with: its file, surroundings and limits.
    spec: JobSpec,
}

#[pymethods]
impl Scene {
    /// Reads the scene at `path`; raises `ValueError` (a bad file, with
    /// `file:line`) or `OSError`.
    #[staticmethod]
    #[pyo3(signature = (path, **flags))]
    fn load(py: Python<'_>, path: PathBuf, flags: Option<&Bound<'_, PyDict>>) -> PyResult<Scene> {
        let mut spec = args::spec_from_flags(flags)?;
        spec.scene = path;
        args::default_output(&mut spec);
        let job = twinray::Job::check(spec.clone()).map_err(py_error)?;
        let loaded = py.detach(|| job.load()).map_err(py_error)?;
        messages(py, &loaded.messages)?;
        Ok(Scene {
            loaded: Arc::new(loaded),
            spec,
        })
    }

    /// The scene file.
    #[getter]
    fn path(&self) -> PathBuf {
        self.spec.scene.clone()
    }

    /// Number of shapes (spheres, triangles, cones), with any floor added.
    #[getter]
    fn shapes(&self) -> usize {
        self.loaded.scene.shapes.len()
    }

    /// Number of point lights, with any added.
    #[getter]
    fn lights(&self) -> usize {
        self.loaded.scene.lights.len()
    }

    /// The scene's triangles as float32 `(N, 3, 3)`: each one's corners
    /// (spheres and cones are left out).
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray3<f32>> {
        let corners: Vec<f32> = self
            .loaded
            .scene
            .shapes
            .iter()
            .filter_map(|s| match s {
                twinray::shapes::Shape::Triangle(t) => Some([t.v0, t.v0 + t.e1, t.v0 + t.e2]),
                _ => None,
            })
            .flat_map(|c| c.into_iter().flat_map(|v| v.to_array()))
            .collect();
        let n = corners.len() / 9;
        numpy::ndarray::Array3::from_shape_vec((n, 3, 3), corners)
            .unwrap_or_else(|_| numpy::ndarray::Array3::zeros((0, 3, 3)))
            .into_pyarray(py)
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene({:?}, shapes={}, lights={})",
            self.spec.scene.display().to_string(),
            self.shapes(),
            self.lights()
        )
    }
}

/// A render of a loaded scene, checked and planned: the camera, the rig
/// (fitted to the scene where automatic) and the method.
///
/// `Job(scene, **flags)` takes `twinray render`'s flags with underscores:
/// `size=(960, 540)`, `stereo=True`, `views=8`, `interaxial=0.2`,
/// `convergence="inf"`, `samples=4`, `fast=True`, `from_=(x, y, z)` (or
/// `**{"from": ...}`), `threads=2`, ... A flag without a value takes
/// `True`. `Job(scene, spec=d)` takes a whole spec dict as
/// `twinray render --print-job` prints it (its scene is `scene`'s).
/// Settings of the scene itself (`ground`, `lights`, `env`, ...) belong to
/// `Scene.load`.
#[pyclass(frozen, module = "twinray._native")]
struct Job {
    job: twinray::Job,
    plan: Plan,
    messages: Vec<(String, String)>,
}

#[pymethods]
impl Job {
    #[new]
    #[pyo3(signature = (scene, spec=None, **flags))]
    fn new(
        py: Python<'_>,
        scene: &Scene,
        spec: Option<&Bound<'_, PyAny>>,
        flags: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Job> {
        let mut spec = match spec {
            Some(dict) => {
                if flags.is_some_and(|f| !f.is_empty()) {
                    return Err(PyValueError::new_err(
                        "Job takes a spec or flags, not both: put the flags in the spec",
                    ));
                }
                JobSpec::from_json(&py_to_json(dict)?).map_err(py_error)?
            }
            None => args::spec_from_flags(flags)?,
        };
        args::take_scene_settings(&mut spec, &scene.spec)?;
        args::default_output(&mut spec);
        let job = twinray::Job::check(spec).map_err(py_error)?;
        let loaded = &scene.loaded;
        let plan = py.detach(|| job.plan(loaded)).map_err(py_error)?;
        let messages = messages(py, &[job.messages(), &plan.messages[..]].concat())?;
        Ok(Job {
            job,
            plan,
            messages,
        })
    }

    /// The job as a spec dict (`twinray render --print-job`'s JSON):
    /// `Job(scene, spec=job.spec)` plans it again.
    #[getter]
    fn spec<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.job.spec().to_json())
    }

    /// The rig as planned: views (offset, shift), interaxial, convergence,
    /// focal length in pixels, the camera.
    #[getter]
    fn rig<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        rig::rig_dict(py, &self.plan)
    }

    /// Views the job renders.
    #[getter]
    fn views(&self) -> usize {
        self.job.views()
    }

    /// The image size of each view, (width, height).
    #[getter]
    fn size(&self) -> (u32, u32) {
        (self.plan.width, self.plan.height)
    }

    /// What checking and planning had to say, as (level, text) pairs:
    /// "info", "note" or "warning" (warnings also went to `warnings`).
    #[getter]
    fn messages(&self) -> Vec<(String, String)> {
        self.messages.clone()
    }

    /// Renders the views, and with `ground_truth` the depth, disparity,
    /// occlusion, out-of-frame and second-layer arrays; returns a dict of
    /// numpy arrays (the package's `Result` wraps it).
    ///
    /// The GIL is released while the views are traced. `progress(done,
    /// total)` is called on this thread about ten times a second; Ctrl-C
    /// (or an exception from `progress`) stops the render within a row of
    /// samples and raises.
    #[pyo3(signature = (progress=None, ground_truth=true))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        progress: Option<Bound<'py, PyAny>>,
        ground_truth: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        render::render(py, self, progress, ground_truth)
    }

    fn __repr__(&self) -> String {
        format!(
            "Job({} view(s) of {}x{}, scene {:?})",
            self.job.views(),
            self.plan.width,
            self.plan.height,
            self.job.spec().scene.display().to_string()
        )
    }
}

/// The 8-bit pixels of linear images `(views, H, W, 3)` as the CLI's PNG
/// files hold them: exposure and tone curve of `spec`, then sRGB (unless
/// its `linear`), quantised.
#[pyfunction]
fn display<'py>(
    py: Python<'py>,
    images: numpy::PyReadonlyArray4<'py, f32>,
    spec: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, numpy::PyArray4<u8>>> {
    render::display(py, images, spec)
}

/// Writes the linear image `(H, W, 3)` to `path` as the CLI writes a view
/// (PNG and JPEG 8-bit with the spec's display transform and sRGB; EXR and
/// PFM as floats), atomically: the file is whole or absent.
#[pyfunction]
fn write_image(
    path: PathBuf,
    image: numpy::PyReadonlyArray3<'_, f32>,
    spec: &Bound<'_, PyAny>,
) -> PyResult<()> {
    render::write_image(path, image, spec)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_class::<Job>()?;
    m.add_function(wrap_pyfunction!(display, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
