//! Readings lost on the way (thesis appendix A: lost CAN frames read as zero): found, so that
//! they are left out, never used as values.

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
    starts.iter().enumerate().flat_map(|(k, &a)| dropouts(&series[a..starts.get(k + 1).copied().unwrap_or(series.len())], uncertainty)).collect()
}
