//! Tests of the model loop's helpers: merging the loop's values and a cause's plant terms, and
//! the held-out part.

use serde_json::{Map, Value};

use super::gain::held_out_mask;
use super::simulation::merge_plant;
use super::write::merge_yaml;

#[test]
fn the_loops_values_merge_into_hal_sim_and_keep_the_rest() {
    let mut sim: serde_yaml::Value = serde_yaml::from_str("{seed: 1, can_latency_s: 0.03, elmo: {kp: 10.0, max_acceleration_rad_s2: 30.0}}").unwrap();
    merge_yaml(&mut sim, &serde_yaml::from_str("{can_latency_s: 0.05, elmo: {max_acceleration_rad_s2: 8.0}}").unwrap());
    assert_eq!(sim, serde_yaml::from_str::<serde_yaml::Value>("{seed: 1, can_latency_s: 0.05, elmo: {kp: 10.0, max_acceleration_rad_s2: 8.0}}").unwrap());
}

#[test]
fn linear_plant_terms_add_and_the_others_replace() {
    let effects = serde_json::json!({"viscous_nms_per_rad": 0.1, "hysteresis": {"sigma_nm_per_rad": 100.0, "limit_nm": 0.2}});
    let fragment: Map<String, Value> = serde_json::from_value(serde_json::json!({"viscous_nms_per_rad": 0.5, "hysteresis": {"sigma_nm_per_rad": 300.0, "limit_nm": 1.0}, "dead_zone_rad": 0.01})).unwrap();
    let merged = merge_plant(&effects, &fragment);
    assert!((merged["viscous_nms_per_rad"].as_f64().unwrap() - 0.6).abs() < 1e-12);
    assert_eq!(merged["hysteresis"]["limit_nm"], 1.0);
    assert_eq!(merged["dead_zone_rad"], 0.01);
}

#[test]
fn the_held_out_part_is_identifys_last_thirty_per_cent_of_the_time_range() {
    let t: Vec<f64> = (0..=10).map(f64::from).collect();
    let d: Vec<f64> = t.iter().map(|t| (1.3 * t).sin()).collect();
    let mask = held_out_mask(&t, &d, super::Split::of(&jointctl_ident::identify::IdentifyOptions::default()));
    assert_eq!(mask.iter().filter(|m| **m).count(), 4);
    assert!(!mask[6] && mask[7]);
}

/// The gains are measured on the samples identify held out, also when it held out a window like
/// the rest: a sine whose amplitude grows tenfold moves the window, and the mask selects exactly
/// the held-out samples of identify's report.
#[test]
fn the_held_out_window_like_the_rest_is_identifys_held_out_part() {
    use jointctl_ident::identify::{IdentifyOptions, identify, prepare::HeldOut};
    let t: Vec<f64> = (0..20_000).map(|i| i as f64 * 0.005).collect();
    let d: Vec<f64> = t.iter().map(|t| (0.005 + 0.0005 * t * t / 10.0) * (std::f64::consts::TAU * 0.5 * t).sin()).collect();
    let tau: Vec<f64> = d.iter().enumerate().map(|(i, x)| 80.0 * x + 0.002 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5)).collect();
    let data = jointctl_ident::csv::Data::from_columns(t.clone(), d.clone(), tau);
    let opts = IdentifyOptions { held_out: HeldOut::LikeTheRest, ..IdentifyOptions::default() };
    let report = identify(&data, &opts).unwrap();
    assert!(report.held_out_window.moved.is_some(), "{:?}", report.held_out_window);
    let mask = held_out_mask(&t, &d, super::Split::of(&opts));
    let masked: Vec<f64> = t.iter().zip(&mask).filter(|(_, m)| **m).map(|(t, _)| *t).collect();
    let held: Vec<f64> = report.held_out.iter().map(|row| row[0]).collect();
    assert_eq!(masked.len(), held.len());
    assert!(masked.iter().zip(&held).all(|(a, b)| (a - b).abs() < 1e-9));
}
