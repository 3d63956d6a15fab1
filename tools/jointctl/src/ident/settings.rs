//! Whether a record's pivot settings are ones identify's baseline knows.

use super::{ConfiguredJoint, IdentifyArgs, MIN_SETTING_SAMPLES};

/// Whether the record's pivot settings are ones its baseline has: without a config the
/// thesis' baseline is one characteristic, so a record of several settings (section 3.4.2's
/// curves 23-335 Nm/rad apart on q2) would be pooled into one and its spread named as causes;
/// with a config whose joint changes with the pivot, every sample needs its setting, within the
/// characteristic's (its table holds the curves between, not beyond: a setting outside would be
/// read as the nearest end's).
pub(super) fn fit_the_baseline(a: &IdentifyArgs, configured: Option<&ConfiguredJoint>, data: &jointctl_ident::csv::Data) -> Result<(), String> {
    let file = a.data.display();
    let Some(cj) = configured else {
        let settings = data.pivot_settings(MIN_SETTING_SAMPLES);
        if settings.len() >= 2 {
            let listed: Vec<String> = settings.iter().map(|(p, _)| format!("{p:.2}")).collect();
            return Err(format!(
                "{file}: {} pivot settings ({} mm): without --config the baseline is one characteristic; identify one setting's record, or give --config and --joint to identify each setting against the joint's own",
                settings.len(),
                listed.join(", ")
            ));
        }
        return Ok(());
    };
    let Some(spec) = cj.spec.as_ref().filter(|_| cj.has_pivot_settings()) else { return Ok(()) };
    let known = spec.pivot_settings_mm();
    let (lo, hi) = (known[0], known[known.len() - 1]);
    if let Some(i) = (0..data.len()).find(|i| !data.pivot_mm_at(*i).is_finite()) {
        return Err(format!(
            "{file}: sample {} (t = {} s): no pivot setting: the joint's model changes with its pivot ({lo}-{hi} mm), so each sample needs its setting (a `pivot_mm` column in a CSV, the pivot's reading in a recording)",
            i + 1,
            data.t[i]
        ));
    }
    // Half a millimetre either side: what the encoder reads of a setting held at an end.
    if let Some(i) = (0..data.len()).find(|i| !(lo - 0.5..=hi + 0.5).contains(&data.pivot_mm_at(*i))) {
        return Err(format!("{file}: sample {} (t = {} s): pivot setting {} mm is outside the joint's characteristic ({lo}-{hi} mm): its model is not known there", i + 1, data.t[i], data.pivot_mm_at(i)));
    }
    Ok(())
}
