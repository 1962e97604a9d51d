//! Identification: the model's parameters from logged moves, and the model against a log.

pub mod calibrate;
pub mod cut;
pub mod hub;
pub mod lsq;
pub mod prescribed;
pub mod replay;
pub mod ringing;
pub mod split;
pub mod units;
pub mod warnings;
