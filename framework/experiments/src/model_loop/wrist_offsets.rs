//! The wrist's torque offsets split from a record along both of section 3.5.2's diagonals
//! (issue 32): the one part of what the diagonals find that belongs to a single DOF, written into
//! each DOF's observer extension and simulated effects, with both gains along the diagonals.
//!
//! Along direction `a` q6 deflects by `sin a` and q7 by `cos a` of the deflection, and the torque
//! along it is `sin a tau6 + cos a tau7`; an offset is even in the deflection, so `o6`, `o7` read
//! `(o6 + o7) / sqrt 2` along 45 deg and `(o6 - o7) / sqrt 2` along 135 deg, and the two
//! diagonals give each (`jointctl identify` splits them). What is odd in the deflection reads
//! alike along both and is not split.

use jointctl_config::LoadedConfig;
use jointctl_ident::csv::Data;
use jointctl_ident::identify::significance::{BlockTest, block_test};
use serde_json::Value;

use super::err;
use super::extension::{DofEffects, Extension};
use super::gain::{Gain, Split, held_out_mask, rmse, squared_errors, trace};
use super::observer::{observer_torque_along, two_dof};
use super::simulation::{PlantEffects, configured_plant, simulated_torque_along, with_other_dofs};
use crate::ExperimentError;

/// One diagonal of a record along both: its direction [deg] and its samples' indices in the
/// record.
#[derive(Clone, Copy, Debug)]
pub struct DiagonalPart<'a> {
    /// The direction [deg] (45 or 135).
    pub angle_deg: f64,
    /// Its samples in the record.
    pub samples: &'a [usize],
}

/// The wrist's extension by its DOFs' torque offsets `offsets_nm` ([first DOF, second DOF], q6
/// and q7 on the reference arm) split from a record along both diagonals: each DOF's
/// `model_extension` entry keeps its other terms and takes its offset (the diagonals were
/// compared with the table alone, which has none: a configured offset is replaced and said so;
/// terms by pivot setting take it at each), and each DOF's simulated effects take it likewise when
/// it makes the simulation's replay of the training parts significantly better (the block t-test
/// every cause's plant terms pass). Both gains are measured along each diagonal on what
/// its identification held out, together. `dof` is the DOF the extension is written as
/// (`--joint`); the other's effects are in [`Extension::other_dofs`].
///
/// ```
/// use jointctl_experiments::model_loop::{DiagonalPart, Split, extend_wrist_offsets, observer_torque_along};
/// let loaded = jointctl_config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.yaml")).unwrap();
/// let params = &loaded.config.joints.iter().find(|j| j.dof_names().contains(&"q7")).unwrap().params.0;
/// // 20 s along 45 deg, then 20 s along 135 deg (100 Hz, at 20 mm): the table's torque and the
/// // offsets q6 0.3 Nm, q7 -0.2 Nm read along each, (0.3 - 0.2) / sqrt 2 and (0.3 + 0.2) / sqrt 2.
/// let (mut t, mut x, mut tau, mut parts) = (Vec::new(), Vec::new(), Vec::new(), [Vec::new(), Vec::new()]);
/// for (k, (angle, read)) in [(45.0, 0.1), (135.0, 0.5)].into_iter().enumerate() {
///     let tk: Vec<f64> = (0..2000).map(|i| 20.0 * k as f64 + i as f64 * 0.01).collect();
///     let xk: Vec<f64> = tk.iter().map(|t| 0.05 * (std::f64::consts::PI * t).sin()).collect();
///     let table = observer_torque_along(params, angle, &tk, &xk, &vec![20.0; tk.len()]).unwrap();
///     parts[k] = (t.len()..t.len() + tk.len()).collect();
///     tau.extend(table.iter().map(|y| y + read * std::f64::consts::FRAC_1_SQRT_2));
///     t.extend(tk);
///     x.extend(xk);
/// }
/// let mut data = jointctl_ident::csv::Data::from_columns(t, x, tau);
/// data.pivot_mm = vec![20.0; data.len()];
/// let diagonals = [DiagonalPart { angle_deg: 45.0, samples: &parts[0] }, DiagonalPart { angle_deg: 135.0, samples: &parts[1] }];
/// let ext = extend_wrist_offsets(&loaded, "q7", [0.3, -0.2], &data, diagonals, Split::of(&Default::default())).unwrap();
/// assert_eq!(ext.observer_params["model_extension"][0]["torque_offset_nm"], 0.3);
/// assert!(ext.observer.rmse_after < 1e-9 && ext.observer.rmse_before > 0.2, "{:?}", ext.observer);
/// ```
///
/// # Errors
/// The DOF's joint has no 2-DOF characteristic or no `sim` section, its effects are by pivot
/// setting (an offset split from one setting's diagonals is written into effects per DOF), its
/// `model_extension` is not a list of one entry per DOF, the parts' samples are not the record's
/// (out of range, out of order, or in both), or a model cannot be evaluated.
pub fn extend_wrist_offsets(loaded: &LoadedConfig, dof: &str, offsets_nm: [f64; 2], data: &Data, diagonals: [DiagonalPart<'_>; 2], split: Split) -> Result<Extension, ExperimentError> {
    let (j, i) = crate::locate(loaded, dof)?;
    let entry = &loaded.config.joints[j];
    let names: Vec<String> = entry.dof_names().iter().map(|n| n.to_string()).collect();
    if !two_dof(&entry.params.0) || names.len() != 2 {
        return Err(err(format!("`{dof}`'s joint `{}` has no 2-DOF characteristic: torque offsets are split along the wrist's diagonals", entry.name)));
    }
    let sim = entry.sim.as_ref().ok_or_else(|| err(format!("joints[{j}] ({}) has no sim section", entry.name)))?;
    if !sim.effects_by_pivot.is_empty() {
        return Err(err(format!(
            "joints[{j}] ({}): its simulated effects are by pivot setting; an offset split from the diagonals is written into `sim.effects_per_dof`",
            entry.name
        )));
    }
    let mut notes = Vec::new();
    let params_before = entry.params.0.clone();
    let params_after = with_offsets(&params_before, offsets_nm, &names, &mut notes)?;
    check_parts(&diagonals, data.len())?;
    // The simulated sensors' offsets replaced as the observer's are: each is the whole offset
    // the diagonals read against the table.
    let mut plant = Vec::new();
    for (d, (o, name)) in offsets_nm.iter().zip(&names).enumerate() {
        let PlantEffects::One(mut effects) = configured_plant(entry, d)? else {
            return Err(err(format!("joints[{j}] ({}): effects by pivot setting", entry.name)));
        };
        let configured = effects.get("torque_offset_nm").and_then(Value::as_f64).unwrap_or(0.0);
        if configured != 0.0 {
            notes.push(format!("{name}'s configured simulated offset ({configured} Nm) is replaced: the diagonals read the whole offset against the table"));
        }
        if let Some(m) = effects.as_object_mut() {
            m.insert("torque_offset_nm".into(), Value::from(*o));
        }
        plant.push(PlantEffects::One(effects));
    }
    let sim_with = with_other_dofs(sim, plant.iter().enumerate())?;

    let n = data.len();
    let nan = || vec![f64::NAN; n];
    let (mut obs_before, mut obs_after, mut sim_before, mut sim_after) = (nan(), nan(), nan(), nan());
    let (mut held_out, mut in_parts) = (vec![false; n], vec![false; n]);
    for part in &diagonals {
        let sub = data.subset(part.samples);
        let mask = held_out_mask(&sub.t, &sub.deflection, split);
        let (t, x, p) = (&sub.t, &sub.deflection, &sub.pivot_mm);
        let columns = [
            observer_torque_along(&params_before, part.angle_deg, t, x, p)?,
            observer_torque_along(&params_after, part.angle_deg, t, x, p)?,
            simulated_torque_along(loaded, j, sim, part.angle_deg, t, x, p)?,
            simulated_torque_along(loaded, j, &sim_with, part.angle_deg, t, x, p)?,
        ];
        for (k, &s) in part.samples.iter().enumerate() {
            held_out[s] = mask[k];
            in_parts[s] = true;
            for (out, column) in [&mut obs_before, &mut obs_after, &mut sim_before, &mut sim_after].into_iter().zip(&columns) {
                out[s] = column[k];
            }
        }
    }
    let training: Vec<bool> = held_out.iter().zip(&in_parts).map(|(h, p)| !h && *p).collect();
    let gain = |mask: &[bool], before: &[f64], after: &[f64]| Gain { rmse_before: rmse(&squared_errors(&data.torque, before, mask, true)), rmse_after: rmse(&squared_errors(&data.torque, after, mask, true)) };
    // Taken into the simulation as any cause's plant terms are, when they make its replay of the
    // training parts significantly better (the block t-test of `plant_choice`): tested on each
    // diagonal apart (each reads its own sum of the offsets, and blocks of both together differ
    // by part, not by chance: 1.3 for a drop from 0.255 to 0.005 Nm), taken when no part is
    // worse and at least one significantly better.
    let tests: Vec<BlockTest> = diagonals
        .iter()
        .map(|part| {
            let mut mask = vec![false; n];
            part.samples.iter().for_each(|&s| mask[s] = training[s]);
            let (a, b) = (squared_errors(&data.torque, &sim_before, &mask, true), squared_errors(&data.torque, &sim_after, &mask, true));
            block_test(&a.iter().zip(&b).map(|(a, b)| a - b).collect::<Vec<f64>>())
        })
        .collect();
    let taken = tests.iter().all(|t| t.mean_nm2 >= 0.0) && tests.iter().any(BlockTest::significant);
    let mut other_dofs = Vec::new();
    let (own, plant_causes) = if taken {
        other_dofs.push(DofEffects { dof: names[1 - i].clone(), index: 1 - i, effects: plant[1 - i].clone() });
        let split = names.iter().zip(offsets_nm).map(|(d, o)| format!("{d} {o:.4} Nm")).collect::<Vec<_>>().join(", ");
        (plant[i].clone(), vec![format!("sensor_offset ({split}, split from the diagonals)")])
    } else {
        let said: Vec<String> = diagonals.iter().zip(&tests).map(|(p, t)| format!("along {} deg block t = {:.2} (critical {:.2})", p.angle_deg, t.t, t.critical)).collect();
        notes.push(format!("the offsets left out of the simulation: they do not make its replay of the training parts significantly better, and worse on none ({}); its effects stay as configured", said.join(", ")));
        sim_after.clone_from(&sim_before);
        (configured_plant(entry, i)?, Vec::new())
    };
    Ok(Extension {
        dof: dof.into(),
        joint_index: j,
        observer_params: params_after,
        plant_effects: own,
        other_dofs,
        plant_causes,
        notes,
        simulation: gain(&held_out, &sim_before, &sim_after),
        observer: gain(&held_out, &obs_before, &obs_after),
        simulation_trace: trace(data, &held_out, &sim_before, &sim_after),
        observer_trace: trace(data, &held_out, &obs_before, &obs_after),
        by_setting: Vec::new(),
    })
}

/// Each part's samples within the record's `n`, in increasing order, and no sample in both.
fn check_parts(diagonals: &[DiagonalPart<'_>; 2], n: usize) -> Result<(), ExperimentError> {
    let mut seen = vec![false; n];
    for part in diagonals {
        if let Some(w) = part.samples.windows(2).find(|w| w[1] <= w[0]) {
            return Err(err(format!("the samples along {} deg are not in increasing order ({} after {})", part.angle_deg, w[1], w[0])));
        }
        for &s in part.samples {
            match seen.get_mut(s) {
                None => return Err(err(format!("sample {s} along {} deg: the record has {n}", part.angle_deg))),
                Some(true) => return Err(err(format!("sample {s} is along both diagonals"))),
                Some(flag) => *flag = true,
            }
        }
    }
    Ok(())
}

/// `params` with each DOF's `model_extension` entry's `torque_offset_nm` set to its offset,
/// its other terms kept (a configured offset replaced, and said in `notes`).
fn with_offsets(params: &Value, offsets_nm: [f64; 2], names: &[String], notes: &mut Vec<String>) -> Result<Value, ExperimentError> {
    let mut after = params.clone();
    let obj = after.as_object_mut().ok_or_else(|| err("params: not a mapping"))?;
    let mut list = match obj.get("model_extension") {
        None | Some(Value::Null) => vec![Value::Null; 2],
        Some(Value::Array(l)) if l.len() == 2 => l.clone(),
        Some(_) => return Err(err("params.model_extension: the wrist's is a list of one entry per DOF, [q6, q7]")),
    };
    for ((entry, o), name) in list.iter_mut().zip(offsets_nm).zip(names) {
        let mut terms = entry.as_object().cloned().unwrap_or_default();
        let replaced = |old: Option<Value>, at: &str| old.map(|old| format!("{name}'s configured observer offset{at} ({old} Nm) is replaced: the diagonals were compared with the table alone"));
        match terms.get_mut("by_pivot").and_then(Value::as_array_mut) {
            // Terms by pivot setting (identified at several): the offset at each, the torque
            // sensor's, whatever the pivot.
            Some(settings) => {
                for setting in settings.iter_mut() {
                    let at = format!(" at {} mm", setting.get("pivot_mm").map_or_else(|| "?".into(), Value::to_string));
                    let Some(setting_terms) = setting.get_mut("terms").and_then(Value::as_object_mut) else {
                        return Err(err(format!("params.model_extension: {name}'s by_pivot setting{at} has no terms")));
                    };
                    notes.extend(replaced(setting_terms.insert("torque_offset_nm".into(), Value::from(o)), &at));
                }
                notes.push(format!("{name}'s observer terms are by pivot setting: its offset is written at each (the torque sensor's, whatever the pivot)"));
            }
            None => notes.extend(replaced(terms.insert("torque_offset_nm".into(), Value::from(o)), "")),
        }
        *entry = Value::Object(terms);
    }
    obj.insert("model_extension".into(), Value::Array(list));
    Ok(after)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_dofs_entry_keeps_its_terms_and_takes_its_offset() {
        let names = ["q6".to_string(), "q7".to_string()];
        let params = serde_json::json!({"model_extension": [null, {"hysteresis": {"limit_nm": 0.2}, "torque_offset_nm": 0.1}]});
        let mut notes = Vec::new();
        let after = with_offsets(&params, [0.3, -0.2], &names, &mut notes).unwrap();
        assert_eq!(after["model_extension"], serde_json::json!([{"torque_offset_nm": 0.3}, {"hysteresis": {"limit_nm": 0.2}, "torque_offset_nm": -0.2}]));
        assert!(notes.len() == 1 && notes[0].starts_with("q7's configured observer offset (0.1 Nm)"), "{notes:?}");
        let one_entry = serde_json::json!({"model_extension": {"torque_offset_nm": 0.1}});
        assert!(with_offsets(&one_entry, [0.3, -0.2], &names, &mut notes).is_err());
    }

    /// From a review: an entry by pivot setting took the offset beside its `by_pivot`, which the
    /// extension refuses ("either flat or by_pivot"); the offset goes into each setting's terms.
    #[test]
    fn an_entry_by_pivot_setting_takes_the_offset_at_each_setting() {
        let names = ["q6".to_string(), "q7".to_string()];
        let settings = serde_json::json!([{"pivot_mm": 10.0, "terms": {"torque_offset_nm": 0.1}}, {"pivot_mm": 30.0, "terms": {}}]);
        let params = serde_json::json!({"model_extension": [null, {"by_pivot": settings}]});
        let mut notes = Vec::new();
        let after = with_offsets(&params, [0.3, -0.2], &names, &mut notes).unwrap();
        let q7 = &after["model_extension"][1];
        assert!(q7.get("torque_offset_nm").is_none(), "{q7}");
        assert_eq!((q7["by_pivot"][0]["terms"]["torque_offset_nm"].as_f64(), q7["by_pivot"][1]["terms"]["torque_offset_nm"].as_f64()), (Some(-0.2), Some(-0.2)));
        assert!(notes.iter().any(|n| n.contains("offset at 10.0 mm (0.1 Nm) is replaced")), "{notes:?}");
    }

    /// From a review: samples out of the record or along both diagonals panicked or were
    /// silently overwritten.
    #[test]
    fn parts_that_are_not_the_records_samples_are_refused() {
        let part = |angle_deg, samples| DiagonalPart { angle_deg, samples };
        assert!(check_parts(&[part(45.0, &[0, 1]), part(135.0, &[2, 3])], 4).is_ok());
        let beyond = check_parts(&[part(45.0, &[0, 1]), part(135.0, &[2, 4])], 4).unwrap_err().to_string();
        assert!(beyond.contains("sample 4 along 135 deg: the record has 4"), "{beyond}");
        assert!(check_parts(&[part(45.0, &[0, 1]), part(135.0, &[1, 2])], 4).unwrap_err().to_string().contains("sample 1 is along both"));
        assert!(check_parts(&[part(45.0, &[1, 0]), part(135.0, &[2])], 4).unwrap_err().to_string().contains("not in increasing order"));
    }
}
