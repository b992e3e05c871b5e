//! Sharing strand work out over Bevy's compute task pool, the calling thread included.

use bevy::tasks::{ComputeTaskPool, TaskPool};

/// The compute task pool (made with defaults when no app made it, as in tests and benches).
pub(crate) fn compute_pool() -> &'static TaskPool {
    ComputeTaskPool::get_or_init(TaskPool::default)
}

/// Threads that work in [`run_parts`]: the pool's own plus the calling thread. On a 2-core
/// machine Bevy gives the compute pool a single thread, and the thread calling `scope` would
/// otherwise only wait.
pub(crate) fn workers(pool: &TaskPool) -> usize {
    pool.thread_num().max(1) + 1
}

/// Runs `work` on every part, in parallel on `pool`; every [`workers`]-th part (the first
/// among them) runs on the calling thread. Returns when all are done.
pub(crate) fn run_parts<'env, T, F>(
    pool: &TaskPool,
    parts: impl IntoIterator<Item = T>,
    work: &'env F,
) where
    T: Send + 'env,
    F: Fn(T) + Sync + 'env,
{
    let workers = workers(pool);
    pool.scope(|scope| {
        for (i, part) in parts.into_iter().enumerate() {
            let task = async move { work(part) };
            if i % workers == 0 {
                scope.spawn_on_scope(task);
            } else {
                scope.spawn(task);
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn every_part_runs_once() {
        let mut data = vec![0u32; 1000];
        let calls = AtomicUsize::new(0);
        run_parts(compute_pool(), data.chunks_mut(7), &|part: &mut [u32]| {
            calls.fetch_add(1, Ordering::Relaxed);
            for x in part {
                *x += 1;
            }
        });
        assert_eq!(calls.load(Ordering::Relaxed), 1000usize.div_ceil(7));
        assert!(data.iter().all(|&x| x == 1));
    }
}
