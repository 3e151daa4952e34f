//! The paper's Table-3 RMSE of normalised curves, for any fitted model.

use super::data::Dataset;

/// RMSE as in the paper's Table 3: per incidence, measured values divided by the
/// measured value at theta_r = theta_i, model values by the model's value there; when
/// an incidence has no reading exactly there, both are normalised at the reading
/// nearest to it; not for an incidence whose reference reading is at or below 0
/// ([`Dataset::normalising_reference`]). One pass over the readings.
/// `model_at(j)` gives incidence `j`'s model as its value
/// at a reading of that incidence, by the reading's index in `data.obs` (None when it
/// cannot be built or evaluated); it is asked once per incidence, so one model is held
/// at a time.
pub fn paper_rmse_with<F: FnMut(usize) -> Option<f64>>(
    data: &Dataset,
    mut model_at: impl FnMut(usize) -> Option<F>,
) -> (Vec<Option<f64>>, Option<f64>) {
    let mut per = Vec::with_capacity(data.incidences.len());
    let (mut sum, mut count) = (0.0, 0usize);
    for j in 0..data.incidences.len() {
        let Some((r, _)) = data.normalising_reference(j) else {
            per.push(None);
            continue;
        };
        let y_ref = data.obs[r].y;
        let Some(mut f) = model_at(j) else {
            per.push(None);
            continue;
        };
        let Some(f_ref) = f(r) else {
            per.push(None);
            continue;
        };
        let (mut s, mut c) = (0.0, 0usize);
        for &k in data.rows_of(j) {
            let o = &data.obs[k];
            let fk = f(k).unwrap_or(f64::NAN);
            let d = o.y / y_ref - fk / f_ref;
            s += d * d;
            c += 1;
        }
        sum += s;
        count += c;
        per.push(Some((s / c as f64).sqrt()));
    }
    (per, (count > 0).then(|| (sum / count as f64).sqrt()))
}
