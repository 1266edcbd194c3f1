//! EMP driver tests: byte conversations on synthetic time (`connect`,
//! `motion`, `faults`), the driver against the simulator model in memory
//! (`with_sim`), and a property test (`properties`).

mod connect;
mod faults;
mod harness;
mod motion;
mod properties;
mod with_sim;
