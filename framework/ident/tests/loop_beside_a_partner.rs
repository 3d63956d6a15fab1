//! A loop searched beside a partner: on a rig record of one repetition (the rig generator's seed
//! 5, device d1; `tests/data/README.md`) the slip-element loop, fitted alone, came out as a loop
//! that runs the other way and was refused on the held-out part; beside the cubic it is the
//! element's own. With the loop of either sign first landed, candidates refused alone for want of
//! held-out evidence were not searched beside the unconfirmed proposal, and the loop was lost
//! (held out 0.118 -> 0.141 Nm, the offset alone). Now they are (`select::select`, "refused
//! alone"), and a partner's departure asks the cause only for what it lacked alone.

use jointctl_ident::identify::{IdentifyOptions, identify};

#[test]
fn a_loop_refused_alone_is_found_beside_the_unconfirmed_proposal() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/rig_seed5_d1_one_repetition.csv");
    let text = std::fs::read_to_string(path).unwrap();
    let data = jointctl_ident::csv::parse(&text, path.as_ref()).unwrap();
    let r = identify(&data, &IdentifyOptions::default()).unwrap();
    let named: Vec<(&str, f64)> = r.causes.iter().map(|c| (c.effect.as_str(), c.params.get("limit_nm").copied().unwrap_or(f64::NAN))).collect();
    // The generator's loop is 1.0 Nm at the major loop's amplitude; a Dahl loop of Bouc-Wen shape
    // takes a part of it on this short record (0.16 Nm when measured), of the element's sign.
    let h = r.causes.iter().find(|c| c.effect == "hysteresis").unwrap_or_else(|| panic!("named {named:?}, held out {} -> {}", r.rmse_before, r.rmse_after));
    assert!(h.params["limit_nm"] > 0.0, "{named:?}");
    assert!(r.causes.iter().any(|c| c.effect == "sensor_offset"), "{named:?}");
    // Held out 0.1176 Nm with the loop, 0.1405 Nm with the offset alone.
    assert!(r.rmse_after < 0.13, "held out {} -> {} ({named:?})", r.rmse_before, r.rmse_after);
}
