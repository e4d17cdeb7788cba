//! A job's render with the GIL released, its progress and Ctrl-C on the
//! calling thread, and the views and ground truth as numpy arrays.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::Duration;

use numpy::ndarray::{Array3, Array4};
use numpy::{IntoPyArray, PyArray4, PyReadonlyArray3, PyReadonlyArray4};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use twinray::ground_truth::GroundTruth;
use twinray::job::{CancelToken, Rendered};
use twinray::math::Color;
use twinray::{Image, JobSpec};

use crate::{py_error, Job};

/// How often the calling thread looks at Ctrl-C and reports progress.
const POLL: Duration = Duration::from_millis(100);

type Outcome = (twinray::Result<Rendered>, Option<Vec<GroundTruth>>);

/// See `Job.render`.
pub fn render<'py>(
    py: Python<'py>,
    job: &Job,
    progress: Option<Bound<'py, PyAny>>,
    ground_truth: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let done = AtomicU64::new(0);
    let total = AtomicU64::new(0);
    let cancel = CancelToken::new();
    let mut stopped: Option<PyErr> = None;
    let (rendered, truth) = std::thread::scope(|s| -> PyResult<Outcome> {
        let (tx, rx) = mpsc::channel::<Outcome>();
        // Waited on with the GIL released, which asks for a shareable receiver.
        let rx = std::sync::Mutex::new(rx);
        let (done, total, cancel) = (&done, &total, &cancel);
        s.spawn(move || {
            let report = |d: u64, t: u64| {
                done.store(d, Ordering::Relaxed);
                total.store(t, Ordering::Relaxed);
            };
            let rendered = job.job.render(&job.plan, &report, cancel);
            let truth = (ground_truth && rendered.is_ok()).then(|| {
                let max_depth = job.job.render_options().trace.max_depth;
                let p = &job.plan;
                job.job
                    .pool()
                    .install(|| GroundTruth::measure_all(&p.world, &p.camera, &p.rig, max_depth))
            });
            // The receiver waits until this is sent.
            let _ = tx.send((rendered, truth));
        });
        let mut last = (u64::MAX, u64::MAX);
        loop {
            let wait = || match rx.lock() {
                Ok(rx) => rx.recv_timeout(POLL),
                Err(_) => Err(mpsc::RecvTimeoutError::Disconnected),
            };
            match py.detach(wait) {
                Ok(outcome) => {
                    if let (Some(cb), None, Ok(_)) = (&progress, &stopped, &outcome.0) {
                        let t = total.load(Ordering::Relaxed);
                        cb.call1((t, t))?;
                    }
                    return Ok(outcome);
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(pyo3::exceptions::PyRuntimeError::new_err(
                        "the render thread stopped without a result",
                    ))
                }
            }
            if stopped.is_some() {
                continue;
            }
            if let Err(e) = py.check_signals() {
                cancel.cancel();
                stopped = Some(e);
                continue;
            }
            let now = (done.load(Ordering::Relaxed), total.load(Ordering::Relaxed));
            if let (Some(cb), true) = (&progress, now != last && now.1 > 0) {
                last = now;
                if let Err(e) = cb.call1(now) {
                    cancel.cancel();
                    stopped = Some(e);
                }
            }
        }
    })?;
    if let Some(e) = stopped {
        return Err(e);
    }
    let rendered = rendered.map_err(py_error)?;
    crate::messages(py, &rendered.messages)?;
    arrays(py, job, &rendered, truth.as_deref())
}

/// The result dict: `images`, and with the ground truth `depth`,
/// `disparity`, `occluded`, `out_of_frame`, `layer2_depth`,
/// `layer2_disparity`; `rig`, `spec`, `seconds`.
fn arrays<'py>(
    py: Python<'py>,
    job: &Job,
    rendered: &Rendered,
    truth: Option<&[GroundTruth]>,
) -> PyResult<Bound<'py, PyDict>> {
    let images = &rendered.output.images;
    let (w, h) = images
        .first()
        .map_or((0, 0), |i| (i.width as usize, i.height as usize));
    let v = images.len();
    let mut rgb = Vec::with_capacity(v * w * h * 3);
    for img in images {
        for c in &img.pixels {
            rgb.extend_from_slice(&c.to_array());
        }
    }
    let shape_error = |e: numpy::ndarray::ShapeError| PyValueError::new_err(e.to_string());
    let d = PyDict::new(py);
    d.set_item(
        "images",
        Array4::from_shape_vec((v, h, w, 3), rgb)
            .map_err(shape_error)?
            .into_pyarray(py),
    )?;
    if let Some(truth) = truth {
        let stack_f32 = |pick: fn(&GroundTruth) -> &Vec<f32>| -> PyResult<_> {
            let all: Vec<f32> = truth.iter().flat_map(|t| pick(t).iter().copied()).collect();
            Ok(Array3::from_shape_vec((v, h, w), all)
                .map_err(shape_error)?
                .into_pyarray(py))
        };
        let stack_bool = |pick: fn(&GroundTruth) -> &Vec<bool>| -> PyResult<_> {
            let all: Vec<bool> = truth.iter().flat_map(|t| pick(t).iter().copied()).collect();
            Ok(Array3::from_shape_vec((v, h, w), all)
                .map_err(shape_error)?
                .into_pyarray(py))
        };
        d.set_item("depth", stack_f32(|t| &t.depth)?)?;
        d.set_item("disparity", stack_f32(|t| &t.disparity)?)?;
        d.set_item("occluded", stack_bool(|t| &t.occluded)?)?;
        d.set_item("out_of_frame", stack_bool(|t| &t.out_of_frame)?)?;
        d.set_item("layer2_depth", stack_f32(|t| &t.layer2_depth)?)?;
        d.set_item("layer2_disparity", stack_f32(|t| &t.layer2_disparity)?)?;
    }
    d.set_item("rig", crate::rig::rig_dict(py, &job.plan)?)?;
    d.set_item("seconds", rendered.output.seconds)?;
    Ok(d)
}

/// The spec dict as a `JobSpec`.
fn spec_of(spec: &Bound<'_, PyAny>) -> PyResult<JobSpec> {
    JobSpec::from_json(&crate::py_to_json(spec)?).map_err(py_error)
}

/// An `(H, W, 3)` array as an image.
fn image_of(a: numpy::ndarray::ArrayView3<'_, f32>) -> PyResult<Image> {
    let (h, w, c) = a.dim();
    if c != 3 {
        return Err(PyValueError::new_err(format!(
            "an image is (H, W, 3), not (H, W, {c})"
        )));
    }
    let pixels = a
        .outer_iter()
        .flat_map(|row| {
            row.outer_iter()
                .map(|p| Color::new(p[0], p[1], p[2]))
                .collect::<Vec<_>>()
        })
        .collect();
    Ok(Image {
        width: w as u32,
        height: h as u32,
        pixels,
    })
}

/// See `twinray.display`.
pub fn display<'py>(
    py: Python<'py>,
    images: PyReadonlyArray4<'py, f32>,
    spec: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray4<u8>>> {
    let spec = spec_of(spec)?;
    let transform = twinray::job::display_transform(&spec.output);
    let opts = twinray::job::write_options(&spec.output);
    let a = images.as_array();
    let (v, h, w, _) = a.dim();
    let mut bytes = Vec::with_capacity(v * h * w * 3);
    for view in a.outer_iter() {
        let img = transform.apply(&image_of(view)?);
        bytes.extend(twinray::output::to_rgb8(&img, &opts));
    }
    Ok(Array4::from_shape_vec((v, h, w, 3), bytes)
        .map_err(|e| PyValueError::new_err(e.to_string()))?
        .into_pyarray(py))
}

/// See `twinray.write_image`.
pub fn write_image(
    path: PathBuf,
    image: PyReadonlyArray3<'_, f32>,
    spec: &Bound<'_, PyAny>,
) -> PyResult<()> {
    let spec = spec_of(spec)?;
    let img = image_of(image.as_array())?;
    let format = twinray::output::ImageFormat::from_path(&path).map_err(py_error)?;
    let img = if format.is_8_bit() {
        twinray::job::display_transform(&spec.output).apply(&img)
    } else {
        img
    };
    twinray::output::write_image(&path, &img, &twinray::job::write_options(&spec.output))
        .map_err(py_error)
}
