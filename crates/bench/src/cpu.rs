//! This thread's CPU time: the monitor's own worst case, apart from the machine's.
//!
//! Issue #16 asks for the p99 of the checks within 1.5x of their median. A wall clock also counts the time the
//! thread did not run: another task's time slice on the same core, and on a virtual machine the time the hypervisor
//! gave the core to another guest (steal). The thread's CPU clock (`CLOCK_THREAD_CPUTIME_ID`) counts only the time
//! the thread ran: on Linux the scheduler's own account of the task, which leaves out preemption and, with
//! paravirtual time accounting (`CONFIG_PARAVIRT_TIME_ACCOUNTING`, the usual setting of cloud kernels), steal time.
//! What it still counts: interrupts served while the thread ran (unless the kernel accounts IRQ time apart), and
//! every slowdown of the thread's own instructions: cache and memory traffic, including another tenant's. So a p99
//! of CPU time above its median is the monitor's (its frames' content, its caches) or the machine's caches, never
//! a time slice lost. `pmon bench` reads it once before and once after each check, outside the wall-clock marks
//! (a system call of about a microsecond on a virtual machine: it does not enter the wall-clock figures).

/// Nanoseconds of CPU time this thread has run so far, or `None` on a platform without a thread CPU clock (the
/// figures that need it are then left out, not estimated).
#[must_use]
pub fn thread_cpu_ns() -> Option<u64> {
    #[cfg(target_os = "linux")]
    {
        let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
        let secs = u64::try_from(t.tv_sec).ok()?;
        let nanos = u64::try_from(t.tv_nsec).ok()?;
        secs.checked_mul(1_000_000_000)?.checked_add(nanos)
    }
    #[cfg(not(target_os = "linux"))]
    {
        None
    }
}

/// Microseconds of this thread's CPU time between two readings of [`thread_cpu_ns`] (`None` if either is).
#[must_use]
pub fn us_between(before: Option<u64>, after: Option<u64>) -> Option<f64> {
    Some(after?.saturating_sub(before?) as f64 / 1e3)
}

/// Runs `f` between two readings of this thread's CPU clock when `read` is true: its result, and the microseconds
/// of CPU time it took (`None` when not read or on a platform without the clock). The readings stand outside
/// whatever `f` times on the wall clock.
pub fn around<T>(read: bool, f: impl FnOnce() -> T) -> (T, Option<f64>) {
    let before = if read { thread_cpu_ns() } else { None };
    let out = f();
    let after = before.and_then(|_| thread_cpu_ns());
    (out, us_between(before, after))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The clock counts work, not waiting: a sleep of 200 ms adds far less than it to the thread's CPU time, and a
    /// loop that runs until the clock has advanced by 5 ms ends (the clock moves while the thread computes).
    #[test]
    #[cfg(target_os = "linux")]
    fn the_thread_clock_counts_work_and_not_sleep() {
        let before = thread_cpu_ns().expect("Linux has a thread CPU clock");
        std::thread::sleep(std::time::Duration::from_millis(200));
        let slept = us_between(Some(before), thread_cpu_ns()).unwrap();
        assert!(slept < 100_000.0, "a 200 ms sleep counted {slept} us of CPU time");
        let start = thread_cpu_ns().unwrap();
        let mut x = 1u64;
        let mut turns = 0u64;
        while thread_cpu_ns().unwrap() < start + 5_000_000 {
            for _ in 0..1000 {
                x = std::hint::black_box(x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1));
            }
            turns += 1;
        }
        assert!(turns > 0 && x != 0);
        assert_eq!(us_between(None, Some(1)), None);
        assert_eq!(us_between(Some(1_000), Some(3_500)), Some(2.5));
    }
}
