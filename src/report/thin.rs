//! Long time series thinned for a figure and its CSV: a plot 1000 pixels wide shows no more
//! than about that many points, and a 200 s M(t) stored every exit would make a CSV of
//! megabytes. The store keeps every sample (`discharge_series`, for SQL).

/// At most `max` (≥ 2) of `series`' samples, evenly spaced by index, with the first and the
/// last always kept, so a curve still starts and ends where the data do.
pub(crate) fn thinned<T: Copy>(series: &[T], max: usize) -> Vec<T> {
    let max = max.max(2);
    if series.len() <= max {
        return series.to_vec();
    }
    let last = series.len() - 1;
    // Index i·last/(max−1) for i = 0..max: increasing, distinct (last ≥ max), ends included.
    (0..max).map(|i| series[i * last / (max - 1)]).collect()
}

#[cfg(test)]
mod tests {
    use super::thinned;

    #[test]
    fn keeps_short_series_and_both_ends_of_long_ones() {
        let short: Vec<u32> = (0..5).collect();
        assert_eq!(thinned(&short, 10), short);
        let long: Vec<u32> = (0..10_001).collect();
        let t = thinned(&long, 1000);
        assert_eq!(t.len(), 1000);
        assert_eq!((t[0], t[999]), (0, 10_000));
        assert!(t.windows(2).all(|w| w[0] < w[1]), "not increasing");
        // Evenly spaced: every gap within one sample of last / (max − 1).
        assert!(t.windows(2).all(|w| (10..=11).contains(&(w[1] - w[0]))));
        assert_eq!(thinned(&long, 1), vec![0, 10_000]);
    }
}
