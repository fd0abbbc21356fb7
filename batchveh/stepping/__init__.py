"""A chunk of variants as one batched model (`batch`), the pure step and scan bodies on MuJoCo C,
MJX and MuJoCo Warp (`rollout`), and the statistics reduced in the scan's carry (`stats`,
`mission_stats`). The engines (`batchveh.engines`) run these; they stand on `batchveh.model`."""
