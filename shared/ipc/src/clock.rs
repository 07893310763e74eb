//! CLOCK_MONOTONIC in nanoseconds: the one clock every timestamp on the wire uses, so
//! latencies can be computed across processes on the same machine.

/// Nanoseconds of CLOCK_MONOTONIC, the same in every process on this machine.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime only writes the timespec we pass; CLOCK_MONOTONIC always exists
    // on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}
