//! Splitting a run's frames into shards ([`ShardPlan`]); `write_shards.rs` writes them.

use crate::error::ShardError;

/// One planned shard: its index in the run, its file name and its frames.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ShardPlan {
    pub index: usize,
    pub file_name: String,
    pub frame_ids: Vec<u64>,
}

/// File name of shard `index`.
pub fn shard_file_name(index: usize) -> String {
    format!("shard-{index:05}.mcap")
}

/// Shard k holds frames `[k F, (k+1) F)` of `frame_ids`, which must be strictly
/// increasing. No frames gives no shards.
pub fn plan_shards(
    frame_ids: &[u64],
    frames_per_shard: usize,
) -> Result<Vec<ShardPlan>, ShardError> {
    if frames_per_shard == 0 {
        return Err(ShardError::ZeroFramesPerShard);
    }
    if let Some(w) = frame_ids.windows(2).find(|w| w[1] <= w[0]) {
        return Err(ShardError::FramesNotSorted {
            previous: w[0],
            next: w[1],
        });
    }
    Ok(frame_ids
        .chunks(frames_per_shard)
        .enumerate()
        .map(|(index, ids)| ShardPlan {
            index,
            file_name: shard_file_name(index),
            frame_ids: ids.to_vec(),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plans_consecutive_ranges() {
        let ids: Vec<u64> = vec![2, 3, 5, 8, 13, 21, 34];
        let plans = plan_shards(&ids, 3).unwrap();
        let got: Vec<(usize, &str, &[u64])> = plans
            .iter()
            .map(|p| (p.index, p.file_name.as_str(), p.frame_ids.as_slice()))
            .collect();
        assert_eq!(
            got,
            vec![
                (0, "shard-00000.mcap", &[2u64, 3, 5][..]),
                (1, "shard-00001.mcap", &[8, 13, 21][..]),
                (2, "shard-00002.mcap", &[34][..]),
            ]
        );
        assert!(plan_shards(&[], 3).unwrap().is_empty());
        assert!(matches!(
            plan_shards(&ids, 0),
            Err(ShardError::ZeroFramesPerShard)
        ));
        assert!(matches!(
            plan_shards(&[1, 4, 4], 2),
            Err(ShardError::FramesNotSorted {
                previous: 4,
                next: 4
            })
        ));
    }
}
