//! Easy Motion Protocol (MSR DRS-500-ECS): 8-byte hex frames ended by 0x1A.
