//! EMP driver tests: byte conversations on synthetic time (`connect`,
//! `motion`, `faults`, `long_actions`), the driver against the simulator model in memory
//! (`with_sim`), and a property test (`properties`).

mod connect;
mod faults;
mod harness;
mod limit_jog;
mod long_actions;
mod motion;
mod probe;
mod properties;
mod traffic;
mod with_sim;
