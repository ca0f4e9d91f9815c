//! The command line's tests, one binary: each module drives the
//! `lidarsim` binary through one capability (see the table in
//! ARCHITECTURE.md); `kit` holds what they share.

mod kit;

mod bench;
mod corpus;
mod disk;
mod interrupt;
mod misuse;
mod parts;
mod real_scans;
mod reliability;
mod render;
mod runs;
mod safety;
mod slurm;
mod survey_errors;
mod waveform;
