//! Latency percentiles (nearest-rank on the sorted samples).

use std::time::Duration;

use serde::Serialize;

/// Summary of latency samples, microseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct LatencyStats {
    /// Samples.
    pub count: usize,
    /// Minimum, µs.
    pub min_us: f64,
    /// Median, µs.
    pub p50_us: f64,
    /// 90th percentile, µs.
    pub p90_us: f64,
    /// 99th percentile, µs.
    pub p99_us: f64,
    /// Maximum, µs.
    pub max_us: f64,
    /// Mean, µs.
    pub mean_us: f64,
}

/// Nearest-rank percentile `p` (0..=100) of ascending `sorted` values; 0 when empty.
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let rank = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

impl LatencyStats {
    /// Statistics of `samples` (all zero when empty).
    pub fn from_samples(samples: &[Duration]) -> Self {
        let mut us: Vec<f64> = samples.iter().map(|d| d.as_secs_f64() * 1e6).collect();
        us.sort_by(f64::total_cmp);
        if us.is_empty() {
            return Self::default();
        }
        Self {
            count: us.len(),
            min_us: us[0],
            p50_us: percentile(&us, 50.0),
            p90_us: percentile(&us, 90.0),
            p99_us: percentile(&us, 99.0),
            max_us: us[us.len() - 1],
            mean_us: us.iter().sum::<f64>() / us.len() as f64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles_of_1_to_100() {
        let s: Vec<Duration> = (1..=100).map(Duration::from_micros).collect();
        let st = LatencyStats::from_samples(&s);
        assert_eq!(st.count, 100);
        assert_eq!((st.p50_us, st.p90_us, st.p99_us), (50.0, 90.0, 99.0));
        assert_eq!((st.min_us, st.max_us), (1.0, 100.0));
        assert!((st.mean_us - 50.5).abs() < 1e-9);
        assert_eq!(LatencyStats::from_samples(&[]).count, 0);
    }
}
