//! The motion of a recording: the program (declared or read from the turntable's angles), where
//! it starts on the IMU clock, the coarse start attitude, and, for recordings without a program,
//! the rests and the turns between them.
//!
//! - [`angles_program`]: the program read from the turntable's angle records;
//! - [`program_start`]: where the program starts on the IMU clock;
//! - [`align`]: coarse alignment of the start attitude to the program's rotations;
//! - [`rests`]: recordings without a program: the rests in place of the program;
//! - [`detect`]: rests found in the records (static detection), for recordings without a
//!   program;
//! - [`sections`]: a session's section list (static faces, rotations) and its known turns;
//! - [`free_motion`]: the coarse start of a hand-turned multi-position recording (no turntable).
//! - [`stamps`]: the records of the rests and turns on time stamps held or counted in a
//!   reading, and readings through ranges of records.

pub mod align;
pub mod angles_program;
pub mod detect;
pub mod free_motion;
pub mod program_start;
pub mod rests;
pub mod sections;
pub mod stamps;
