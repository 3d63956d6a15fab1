//! How identify read the record, in the report's words: the held-out window, a slow log's bins
//! and rate, a friction record's stops.

/// Which part of the record the baseline was fitted on and which part scored it.
pub(super) fn split_sentence(w: &jointctl_ident::identify::prepare::HeldOutWindow) -> String {
    let percent = |f: f64| format!("{:.0}", 100.0 * f);
    match &w.moved {
        None => format!("Baseline fitted on the first {} % of the time range, scored on the last {} %.", percent(w.start), percent(w.end - w.start)),
        Some(why) => format!("Baseline fitted on the time range but {}-{} %, scored on that window: {why}.", percent(w.start), percent(w.end)),
    }
}

/// How a slow log was read, when as bin averages (point samples go unsaid: every record was
/// read so before).
pub(super) fn bins_sentence(b: Option<&jointctl_ident::identify::bin_reading::BinAverages>) -> String {
    b.map_or(String::new(), |b| {
        format!(
            " Read as bin averages (each sample the mean over its interval, eq. 3.5's friction averaged as the rate turns within it): the baseline's training BIC {:.0} against {:.0} read as point samples (k_b {:.4} s/rad against {:.4}); {}.",
            b.bic_bins, b.bic_points, b.k_b_bins_s_per_rad, b.k_b_points_s_per_rad, b.evidence
        )
    })
}

/// The rate read otherwise than over the usual window, when it is.
pub(super) fn narrow_rate_sentence(r: Option<&jointctl_ident::identify::bin_reading::NarrowRate>) -> String {
    use jointctl_ident::identify::bin_reading::RateWindow;
    r.map_or(String::new(), |r| {
        // The narrow window is judged on the baseline's fit, the cubic, the sharper intervals
        // and the wider windows on the whole model's against the first pass's reading.
        let (judged, against) = match r.window {
            RateWindow::OneSampleEitherSide => ("the baseline's training BIC", "over the usual window"),
            RateWindow::CubicTwoEitherSide | RateWindow::Sharper { .. } | RateWindow::Wider { .. } | RateWindow::Crossings { .. } => ("the whole model's training BIC", "as identify read it first"),
        };
        let usual = match r.window {
            RateWindow::Sharper { .. } => "a window is kept while its slope agrees with every narrower one's to within three standard errors of the deflection's scatter and the most its quantisation can tilt it".to_string(),
            RateWindow::Wider { .. } => format!("no wider than the local period over {} either side", jointctl_ident::identify::prepare::VELOCITY_WINDOWS_PER_PERIOD),
            _ => format!("at least {} samples either side", jointctl_ident::identify::prepare::NARROWEST_RATE_WINDOW),
        };
        format!(" The rate read {}; usually {usual}. Judged by {judged} {:.0} against {:.0} {against}; {}.", r.window.describe(), r.bic_narrow, r.bic_usual, r.evidence)
    })
}

/// What a friction record's stops held, its turns, and the error over every held-out sample,
/// when they are left out.
pub(super) fn rest_sentence(r: Option<&jointctl_ident::identify::prepare::AtRest>) -> String {
    r.map_or(String::new(), |r| {
        let figure = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.4}"));
        let mut s = String::new();
        if r.samples > 0 {
            s += &format!(
                " Stops: {} samples ({:.1} s, {} of them held out) at rest (the rate below one count per {} s for at least as long), where the friction is static and held {} to {} Nm, set by what held the joint and not by its motion: left out of the fit and the judgement.",
                r.samples,
                r.seconds,
                r.held_out_samples,
                jointctl_ident::identify::prepare::REST_S,
                r.torque_range_nm[0].map_or("-".into(), |x| format!("{x:.3}")),
                r.torque_range_nm[1].map_or("-".into(), |x| format!("{x:.3}")),
            );
        }
        if r.turn_samples > 0 {
            s += &format!(
                " Turns: {} samples ({} of them held out) where the reading stays on the count at which the motion turned: the encoder cannot say which way the joint moves there, nor the friction's sign: left out of the fit and the judgement.",
                r.turn_samples, r.turn_held_out_samples
            );
        }
        let what = match (r.samples > 0, r.turn_samples > 0) {
            (true, true) => "stops and turns",
            (true, false) => "stops",
            _ => "turns",
        };
        s + &format!(
            " The figures below are over the samples that slide; over every held-out sample, {what} included: baseline {} Nm, extended {} Nm{}.",
            figure(r.rmse_before_all_nm),
            figure(r.rmse_after_all_nm),
            r.held_nm.map_or(String::new(), |h| format!(" (the stops predicted holding {h:.3} Nm in the direction the joint last slid, fitted on the training part's stops)"))
        )
    })
}
