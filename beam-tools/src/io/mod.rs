//! Files and plots: parameter files, the paper's figures, and output files written whole.

pub mod files;
pub mod params_file;
pub mod plot;
pub mod table_file;
