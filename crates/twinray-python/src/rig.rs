//! The planned rig and camera as a Python dict.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use twinray::job::Plan;

/// `{"width", "height", "views": [{"offset", "shift"}], "interaxial",
/// "convergence", "effective_convergence", "focal_px", "camera": {...}}`.
pub fn rig_dict<'py>(py: Python<'py>, plan: &Plan) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("width", plan.width)?;
    d.set_item("height", plan.height)?;
    let views = PyList::empty(py);
    for v in &plan.rig.views {
        let view = PyDict::new(py);
        view.set_item("offset", v.offset)?;
        view.set_item("shift", v.shift)?;
        views.append(view)?;
    }
    d.set_item("views", views)?;
    d.set_item("interaxial", plan.interaxial)?;
    d.set_item("convergence", plan.rig.convergence)?;
    d.set_item("effective_convergence", plan.rig.effective_convergence)?;
    d.set_item("focal_px", plan.camera.focal_pixels())?;
    let c = &plan.camera;
    let camera = PyDict::new(py);
    camera.set_item("eye", c.eye.to_array())?;
    camera.set_item("forward", c.forward.to_array())?;
    camera.set_item("right", c.right.to_array())?;
    camera.set_item("up", c.up.to_array())?;
    camera.set_item("hither", c.hither)?;
    camera.set_item("pixel_size", c.pixel_size)?;
    d.set_item("camera", camera)?;
    Ok(d)
}
