//! predict-grf's own files: the predicted ground reactions per foot
//! (`<name>_predicted_grf.sto`), the comparison metrics against measured
//! loads (`<name>_grf_comparison.csv`) and the predicted loads as an
//! OpenSim ExternalLoads pair (`<name>_predicted_grf.mot` and `.xml`).

use std::path::{Path, PathBuf};

use crate::contacts::ground::FootLoads;
use crate::error::{Error, Location, Result};
use crate::forces::external_loads::ForceLayout;
use crate::metrics::grf::{AxisMetrics, StanceMetrics};
use crate::storage::StoWriter;
use crate::writers::names::{OutputKind, RunKey, Sweep};

/// Write `<name>_predicted_grf.sto`: per foot, the force on the foot
/// (ground frame), the centre of pressure on the floor and the free moment.
pub fn write_foot_loads(loads: &FootLoads, path: &Path, setup: &Path) -> Result<()> {
    let mut labels = Vec::new();
    for side in ['r', 'l'] {
        for what in [
            "force_vx",
            "force_vy",
            "force_vz",
            "cop_px",
            "cop_py",
            "cop_pz",
            "free_moment_ty",
        ] {
            labels.push(format!("{side}_{what}"));
        }
    }
    let mut w = StoWriter::create_for_setup(
        setup,
        path,
        "Predicted ground reactions",
        "Per foot: force on the foot (N, ground), centre of pressure on the floor (m, ground; NaN without load) and free moment about the floor normal (N m).\n",
        &labels,
        8,
        false,
    )?;
    for i in 0..loads.time.len() {
        let mut row = Vec::with_capacity(14);
        for s in 0..2 {
            let (f, p) = (loads.force[s][i], loads.cop[s][i]);
            let p = p.map(|x| if x.is_finite() { x } else { 0.0 });
            row.extend([f.x, f.y, f.z, p.x, p.y, p.z, loads.free_moment[s][i]]);
        }
        w.write_row(loads.time[i], &row)?;
    }
    w.finish()
}

/// Write `<name>_root_residual.sto`: per frame, the size of the summed
/// force on the pelvis translations (N) and as a share of body weight (%).
pub fn write_root_residual(
    root_residual: &[(f64, f64)],
    body_weight: f64,
    path: &Path,
    setup: &Path,
) -> Result<()> {
    let mut w = StoWriter::create_for_setup(
        setup,
        path,
        "Root residual",
        "Per frame: the size of the summed force of every actuator on the pelvis translations (N; residuals and reserves included) and as a share of body weight (%).\n",
        &["root_residual_force".to_string(), "root_residual_percent_bw".to_string()],
        8,
        false,
    )?;
    for &(t, f) in root_residual {
        w.write_row(t, &[f, 100.0 * f / body_weight])?;
    }
    w.finish()
}

/// Write the comparison metrics (per foot and axis) as CSV.
pub fn write_metrics(
    metrics: &[AxisMetrics],
    stance: &[StanceMetrics],
    path: &PathBuf,
) -> Result<()> {
    let err = |e: csv::Error| Error::input(Location::file(path), e.to_string());
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "foot",
        "axis",
        "rho",
        "rmse_N",
        "rmse_percent_bw",
        "peak_error_N",
        "cop_error_mm",
        "heel_strike_error_ms",
        "toe_off_error_ms",
    ])
    .map_err(err)?;
    for m in metrics {
        let st = stance.iter().find(|s| s.side == m.side);
        let f = |v: Option<f64>| v.map(|x| format!("{x:.1}")).unwrap_or_default();
        w.write_record([
            m.side.to_string(),
            m.axis.to_string(),
            format!("{:.4}", m.rho),
            format!("{:.2}", m.rmse_n),
            format!("{:.2}", m.rmse_bw),
            format!("{:.2}", m.peak_error_n),
            f(st.map(|s| s.cop_error_mm)),
            f(st.map(|s| s.heel_strike_error_ms)),
            f(st.map(|s| s.toe_off_error_ms)),
        ])
        .map_err(err)?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| Error::input(Location::file(path), e.to_string()))?;
    crate::storage::results::write(path, bytes)
}

/// Write `<name>_predicted_grf.mot` and `.xml`: per ExternalForce of the
/// layout, the predicted loads of the foot of its body (force and point in
/// ground, the free moment as a torque about the vertical).
pub fn write_external_loads(
    loads: &FootLoads,
    layout: &[ForceLayout],
    dir: &Path,
    name: &str,
    setup_file: &Path,
) -> Result<(PathBuf, PathBuf)> {
    let own = RunKey::setup(name, Sweep::Single);
    let mot = dir.join(own.file(OutputKind::PredictedGrfMot));
    let xml = dir.join(own.file(OutputKind::PredictedGrfXml));
    let mut labels = Vec::new();
    for f in layout {
        for id in [
            &f.force_identifier,
            &f.point_identifier,
            &f.torque_identifier,
        ] {
            if !id.is_empty() {
                labels.extend(["x", "y", "z"].iter().map(|a| format!("{id}{a}")));
            }
        }
    }
    let mut w = StoWriter::create_for_setup(
        setup_file,
        &mot,
        "predicted_grf",
        "Ground reactions predicted by statopt predict-grf (force N, point m, torque N m; ground frame).\n",
        &labels,
        8,
        false,
    )?;
    // Several plates under one foot: the first of them carries the foot's
    // loads, the others nothing (else the foot would be loaded twice).
    let first_of_foot: Vec<bool> = layout
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let side = f.body.ends_with("_l");
            !layout[..k].iter().any(|g| g.body.ends_with("_l") == side)
        })
        .collect();
    for i in 0..loads.time.len() {
        let mut row = Vec::with_capacity(labels.len());
        for (f, &first) in layout.iter().zip(&first_of_foot) {
            let s = usize::from(f.body.ends_with("_l"));
            let gain = if first { 1.0 } else { 0.0 };
            let force = loads.force[s][i] * gain;
            let cop = loads.cop[s][i].map(|x| if x.is_finite() { x } else { 0.0 });
            if !f.force_identifier.is_empty() {
                row.extend(force.iter());
            }
            if !f.point_identifier.is_empty() {
                row.extend(cop.iter());
            }
            if !f.torque_identifier.is_empty() {
                row.extend([0.0, gain * loads.free_moment[s][i], 0.0]);
            }
        }
        w.write_row(loads.time[i], &row)?;
    }
    w.finish()?;
    let mut objects = String::new();
    for f in layout {
        objects.push_str(&format!(
            "\t\t\t<ExternalForce name=\"{}\">\n\t\t\t\t<applied_to_body>{}</applied_to_body>\n\t\t\t\t<force_expressed_in_body>ground</force_expressed_in_body>\n\t\t\t\t<point_expressed_in_body>ground</point_expressed_in_body>\n\t\t\t\t<force_identifier>{}</force_identifier>\n\t\t\t\t<point_identifier>{}</point_identifier>\n\t\t\t\t<torque_identifier>{}</torque_identifier>\n\t\t\t</ExternalForce>\n",
            f.name, f.body, f.force_identifier, f.point_identifier, f.torque_identifier
        ));
    }
    let datafile = mot
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let text = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n<!-- Ground reactions predicted by statopt predict-grf; replaces the measured loads in an OpenSim or statopt setup. -->\n<OpenSimDocument Version=\"40000\">\n\t<ExternalLoads name=\"predicted_grf\">\n\t\t<objects>\n{objects}\t\t</objects>\n\t\t<groups />\n\t\t<datafile>{datafile}</datafile>\n\t</ExternalLoads>\n</OpenSimDocument>\n"
    );
    crate::storage::results::write(&xml, text.into_bytes())?;
    Ok((mot, xml))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::storage;
    use nalgebra::Vector3;
    /// The predicted loads in a measured layout with three plates under the
    /// right foot (`ground_force_calcn_r` style names) and one under the
    /// left: each foot is loaded once (the first of its plates carries it),
    /// not once per plate.
    #[test]
    fn predicted_loads_load_each_foot_once_whatever_its_plates() {
        let tmp = crate::test_dir::TempDir::new("plates");
        let dir = tmp.path().to_path_buf();
        let plate = |name: &str, body: &str, id: &str| ForceLayout {
            name: name.into(),
            body: body.into(),
            force_identifier: format!("{id}_v"),
            point_identifier: format!("{id}_p"),
            torque_identifier: format!("{id}_m"),
        };
        let layout = [
            plate("r1", "calcn_r", "ground_force_calcn_r"),
            plate("r2", "calcn_r", "1_ground_force"),
            plate("l1", "calcn_l", "L_ground_force"),
            plate("r3", "calcn_r", "3_ground_force"),
        ];
        let loads = FootLoads {
            time: vec![0.0, 0.01],
            force: [
                vec![Vector3::new(1.0, 700.0, 2.0); 2],
                vec![Vector3::new(-1.0, 100.0, 0.0); 2],
            ],
            cop: [
                vec![Vector3::new(0.1, 0.0, 0.2); 2],
                vec![Vector3::zeros(); 2],
            ],
            free_moment: [vec![0.5; 2], vec![0.0; 2]],
        };
        let (mot, _) =
            write_external_loads(&loads, &layout, &dir, "t", &dir.join("setup.xml")).unwrap();
        let t = storage::read(&mot).unwrap();
        let sum = |ids: &[&str]| -> f64 {
            ids.iter()
                .map(|id| t.rows[0][t.column_index(&format!("{id}_vy")).unwrap()])
                .sum()
        };
        assert_eq!(
            sum(&["ground_force_calcn_r", "1_ground_force", "3_ground_force"]),
            700.0
        );
        assert_eq!(sum(&["L_ground_force"]), 100.0);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
