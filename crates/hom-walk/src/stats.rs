//! The few statistics the reports and tables share: one median, one mean,
//! one way to print an optional figure. `hom_walk::report` re-exports them.

/// Median of a list (mean of the middle two for an even count); 0 for none.
pub fn median(values: impl IntoIterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) * 0.5
    }
}

/// Mean of a list; `None` for none.
pub fn mean(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (n, sum) = values.into_iter().fold((0usize, 0.0), |(n, s), x| (n + 1, s + x));
    (n > 0).then(|| sum / n as f64)
}

/// `v` with `decimals` digits after the point, `-` for none: how the tables
/// print an optional figure. `-0.0` (a sum of nothing, rounding) prints as `0`.
pub fn fmt_opt(v: Option<f64>, decimals: usize) -> String {
    // `+ 0.0` turns -0.0 into 0.0.
    v.map_or_else(|| "-".to_string(), |v| format!("{:.decimals$}", v + 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_even_and_empty() {
        assert_eq!(median([3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median([4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median([]), 0.0);
        assert_eq!(median([f64::NAN, 5.0]), 5.0);
    }

    #[test]
    fn fmt_opt_prints_none_as_a_dash_and_minus_zero_as_zero() {
        assert_eq!(fmt_opt(Some(1.234), 2), "1.23");
        assert_eq!(fmt_opt(Some(-0.0), 1), "0.0");
        assert_eq!(fmt_opt(Some(12.4), 0), "12");
        assert_eq!(fmt_opt(None, 2), "-");
    }

    #[test]
    fn mean_of_some_and_none() {
        assert_eq!(mean([1.0, 2.0, 6.0]), Some(3.0));
        assert_eq!(mean([]), None);
    }
}
