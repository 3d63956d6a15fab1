//! Readings lost on the way (thesis appendix A: lost CAN frames read as zero): found, so that
//! they are left out, never used as values.

use crate::identify::numeric::segment_ranges;

/// Exact zeros that the signal cannot have reached: a run of zeros far from the line between the
/// readings either side of it, farther than three times a reading's uncertainty (`uncertainty`:
/// the encoder's resolution, the torque sensor's noise) plus twice the signal's own local step
/// per sample of the run. (A signal that really crosses zero lies on that line: a fast
/// stroke crossing zero between a reading above and one below is no dropout, however large its
/// steps; thesis appendix A's lost CAN frames jump to zero from anywhere and back.)
pub(super) fn dropouts(series: &[f64], uncertainty: f64) -> Vec<bool> {
    let n = series.len();
    let mut dropped = vec![false; n];
    let mut i = 1;
    while i + 1 < n {
        if series[i] != 0.0 {
            i += 1;
            continue;
        }
        let mut j = i;
        while j < n && series[j] == 0.0 {
            j += 1;
        }
        if j < n {
            let (before, after) = (series[i - 1], series[j]);
            // The signal's local step per sample: the change into the run's left neighbour and
            // out of its right one, each from the nearest reading beyond it that is not zero (a
            // dropout next to it is no step of the signal: two lost readings one sample apart
            // made each other's steps the signal's full value, and both were kept).
            let step_in = (0..i - 1).rev().find(|k| series[*k] != 0.0).map_or(0.0, |k| (series[i - 1] - series[k]).abs() / (i - 1 - k) as f64);
            let step_out = (j + 1..n).find(|k| series[*k] != 0.0).map_or(0.0, |k| (series[k] - series[j]).abs() / (k - j) as f64);
            let reach = 3.0 * uncertainty + 2.0 * step_in.max(step_out) * (j - i + 1) as f64;
            let span = (j - i + 1) as f64;
            let nearest = (1..=j - i).map(|k| (before + (after - before) * k as f64 / span).abs()).fold(f64::INFINITY, f64::min);
            if nearest > reach && before.abs() > reach && after.abs() > reach {
                dropped[i..j].iter_mut().for_each(|d| *d = true);
            }
        }
        i = j;
    }
    dropped
}

/// [`dropouts`] in each segment of contiguous logging apart (`starts` from [`super::segment_starts`]):
/// a record that starts from rest after a gap (a repetition, an experiment's next sine) reads
/// exactly zero there, and the reading before the gap is no neighbour of it.
pub(super) fn dropouts_by_segment(series: &[f64], starts: &[usize], uncertainty: f64) -> Vec<bool> {
    segment_ranges(starts, series.len()).flat_map(|r| dropouts(&series[r], uncertainty)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use super::super::ENCODER_LSB_RAD;

    #[test]
    fn a_segment_that_starts_from_rest_after_a_gap_is_not_a_dropout() {
        // Finding (issue 32, an experiment's sines recorded one after the other, each from
        // rest): the torque read exactly zero in the first samples after the 1 s gap (the
        // simulator's sensor before it had read; a real logger may start so too), the reading
        // before the gap (-0.143 Nm) was taken as their neighbour, and they were dropped as
        // lost frames. Across a gap there is no neighbour to judge a zero by.
        let torque = [-0.113, -0.138, -0.143, 0.0, 0.0, 0.0, 0.0, -0.0896, -0.0946, -0.0996];
        let starts = [0, 3];
        let whole = dropouts(&torque, 0.01);
        assert!(whole[3..7].iter().all(|d| *d), "the finding: {whole:?}");
        assert!(!dropouts_by_segment(&torque, &starts, 0.01).iter().any(|d| *d));
    }

    #[test]
    fn a_zero_the_signal_passes_through_is_not_a_dropout_but_a_jump_to_zero_is() {
        // A slow ramp through zero, sampled so that one reading is exactly zero.
        let ramp: Vec<f64> = (-50..50).map(|i| i as f64 * ENCODER_LSB_RAD).collect();
        assert!(!dropouts(&ramp, ENCODER_LSB_RAD).iter().any(|d| *d));
        // Two counts either side of an exact zero: quantisation explains it.
        let near = [0.1, 2.0 * ENCODER_LSB_RAD, 0.0, -2.0 * ENCODER_LSB_RAD, -0.1];
        assert!(!dropouts(&near, ENCODER_LSB_RAD)[2]);
        // A zero in the middle of 0.05 rad: a lost frame.
        let mut lost = vec![0.05; 100];
        lost[40] = 0.0;
        assert_eq!(dropouts(&lost, ENCODER_LSB_RAD).iter().filter(|d| **d).count(), 1);
        // Finding (issue 31): a fast stroke of five counts a sample that reads exactly zero as
        // it crosses (between +5 and -5 counts) was taken for a lost frame, the record's slow
        // parts having made the typical step zero.
        let mut record = vec![0.0; 200];
        for (k, x) in record.iter_mut().enumerate().skip(100) {
            *x = (150.0 - k as f64) * 5.0 * ENCODER_LSB_RAD;
        }
        record[..100].iter_mut().enumerate().for_each(|(k, x)| *x = 0.1 + k as f64 * 1e-9);
        assert_eq!(record[150], 0.0);
        assert!(!dropouts(&record, ENCODER_LSB_RAD).iter().any(|d| *d));
        // Finding (issue 36): a torque quantised to 1/640 Nm with 0.03 Nm of noise read exactly
        // zero between -0.014 and -0.027 Nm, and was taken for a lost frame (uncertainty 0).
        let torque = [-0.0125, -0.014062, 0.0, -0.026563, -0.029688];
        assert!(dropouts(&torque, 0.0)[2]);
        assert!(!dropouts(&torque, 0.03)[2]);
    }

    #[test]
    fn lost_readings_next_to_each_other_are_all_found() {
        // Finding (issue 36, the project's generator at 1.4 % lost frames): a run of two zeros
        // and a single zero one reading after it, on a slow stroke at 0.09 rad. Each run's
        // local step was taken across the other run (0.09 rad a sample), and neither was found:
        // the rate read +-9 rad/s there.
        let mut record: Vec<f64> = (0..100).map(|k| 0.095 - k as f64 * 2e-4).collect();
        for k in [40, 41, 43] {
            record[k] = 0.0;
        }
        let found: Vec<usize> = dropouts(&record, ENCODER_LSB_RAD).iter().enumerate().filter(|(_, d)| **d).map(|(k, _)| k).collect();
        assert_eq!(found, vec![40, 41, 43]);
    }
}
