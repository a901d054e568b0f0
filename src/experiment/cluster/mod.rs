//! Experiments on a cluster: a run as a plan of independent jobs (docs/cluster.md).
//!
//! `stokes experiment CONFIG --plan` writes the run folder with `plan.json` and `jobs.jsonl`
//! ([`plan`]); `stokes job RUN_DIR [INDEX]` runs one job ([`job`]): a shard of the reference
//! (a sample range, merged exactly) or one variant and repeat at every budget of a mode, or one
//! grid cell; `stokes experiment --collect RUN_DIR` checks that every job finished, merges the
//! shards and writes the metrics and figures as a run on one machine does ([`collect`]).
//! Scheduling, transport and retries are Slurm's: [`slurm`] writes the array and collect
//! scripts of `stokes experiment --slurm` and submits them.

pub mod collect;
pub mod job;
pub mod plan;
pub mod slurm;

pub use collect::collect;
pub use job::{job_index, run_all, run_job};
pub use plan::write_plan;
