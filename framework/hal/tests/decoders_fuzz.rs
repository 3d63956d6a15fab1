//! The decoders never panic on any input, and round-trip what they encode.

use jointctl_hal::codec::{as5048, canopen::*, netft};
use jointctl_hal::condition::{Conditioner, Plausibility, Sample};
use proptest::prelude::*;

fn any_frame() -> impl Strategy<Value = Frame> {
    (0u16..0x800, 0u8..=15, any::<[u8; 8]>()).prop_map(|(id, len, data)| Frame { id, len, data })
}

proptest! {
    #[test]
    fn canopen_decoders_never_panic(f in any_frame()) {
        let _ = decode_tpdo1(&f);
        let _ = decode_rpdo1(&f);
        let _ = decode_heartbeat(&f);
        let _ = decode_emcy(&f).map(|e| e.class());
        let _ = decode_sdo_response(&f);
        let _ = decode_sdo_request(&f);
        let _ = f.bytes();
    }

    #[test]
    fn statusword_decoding_is_total(s in any::<u16>()) {
        let state = state_of(s);
        let _ = next_controlword(state);
    }

    #[test]
    fn pdos_round_trip(node in 1u8..=127, word in any::<u16>(), counts in any::<i32>(), torque in any::<i16>()) {
        let t = decode_tpdo1(&tpdo1(node, word, counts)).unwrap();
        prop_assert_eq!((t.node, t.statusword, t.position_counts, t.torque_permille), (node, word, counts, None));
        let t = decode_tpdo1(&tpdo1_with_torque(node, word, counts, torque)).unwrap();
        prop_assert_eq!((t.node, t.statusword, t.position_counts, t.torque_permille), (node, word, counts, Some(torque)));
        prop_assert_eq!(decode_rpdo1(&rpdo1(node, word, counts)), Some((node, word, counts)));
    }

    #[test]
    fn as5048_decoding_is_total_and_round_trips(word in any::<u16>(), counts in 0u16..16384) {
        let _ = as5048::decode(word);
        prop_assert_eq!(as5048::decode(as5048::encode(counts)), Ok(counts));
        // Any single flipped bit is caught by the parity.
        for bit in 0..16 {
            prop_assert!(as5048::decode(as5048::encode(counts) ^ (1 << bit)) != Ok(counts));
        }
        let rad = as5048::counts_to_rad(counts);
        prop_assert_eq!(as5048::rad_to_counts(rad), counts);
    }

    #[test]
    fn the_conditioner_never_panics_and_never_passes_a_non_finite_value(
        samples in proptest::collection::vec((any::<f64>(), 0u8..3), 1..50)
    ) {
        let mut c = Conditioner::new(Plausibility::absolute_encoder(3.0));
        for (i, (v, kind)) in samples.into_iter().enumerate() {
            let s = match kind { 0 => Sample::Value { value: v, age_s: 0.0 }, 1 => Sample::Missing, _ => Sample::Invalid };
            let r = c.update(s, i as f64 * 0.025);
            if let Some(x) = r.usable(1.0) { prop_assert!(x.is_finite()); }
        }
    }

    #[test]
    fn the_rdt_decoder_never_panics_and_round_trips(bytes in proptest::collection::vec(any::<u8>(), 0..80), counts in any::<[i32; 6]>(), seq in any::<u32>()) {
        let _ = netft::decode(&bytes);
        let _ = netft::decode_request(&bytes);
        let r = netft::RdtRecord { rdt_sequence: seq, ft_sequence: seq.wrapping_mul(3), status: seq & netft::STATUS_ERROR, counts };
        prop_assert_eq!(netft::decode(&netft::encode(&r)), Ok(r));
        let t = netft::torque_about_axis(&r, 1e6, 1e6, [0.3, -0.2, 1.0], [0.01, 0.02, 0.03]);
        prop_assert!(t.is_finite());
    }

    #[test]
    fn a_torque_sensor_conditioner_passes_any_finite_change_and_no_non_finite_value(values in proptest::collection::vec(any::<f64>(), 1..50)) {
        let mut c = Conditioner::new(Plausibility::torque_sensor());
        for (i, v) in values.into_iter().enumerate() {
            let r = c.update(Sample::Value { value: v, age_s: 0.0 }, i as f64 * 0.025);
            match r.usable(0.0) {
                Some(x) => prop_assert_eq!(x, v),
                None => prop_assert!(!v.is_finite()),
            }
        }
    }
}
