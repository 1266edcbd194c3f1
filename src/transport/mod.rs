//! Byte transports between jogterm and a controller: a real serial port, a
//! pseudo-terminal, or an in-process socket pair to a built-in simulator. The
//! protocol code above never knows which one it talks through.
