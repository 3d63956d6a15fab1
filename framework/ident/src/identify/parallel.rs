//! Work spread over the machine's cores: identify's candidates, checks and the rate's blocks.
//! A leaf: it knows nothing of causes, models or data, and every other module may use it.

/// The cores to spread work over (1 when the system does not say).
pub(crate) fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `f` of every item, in the items' order, spread over the cores: each worker takes the next
/// item left, so put the costly ones first. The calling thread is one of the workers: with
/// every worker a new thread, what each freed stayed with its own allocator arena, and a
/// 2-million-sample sine peaked at 153 MB resident for 142 so (issue 13's bound is 150). A
/// panic in `f` (a registered cause's bug) is passed on, not swallowed: a candidate silently
/// lost would make a wrong report.
pub(crate) fn parallel_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let threads = cores().min(items.len()).max(1);
    if threads == 1 {
        // One item or one core: no thread to start.
        return items.iter().map(f).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let (f, next) = (&f, &next);
    let work = move || {
        let mut mine = Vec::new();
        loop {
            let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let Some(item) = items.get(i) else { return mine };
            mine.push((i, f(item)));
        }
    };
    let mut done: Vec<(usize, R)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (1..threads).map(|_| scope.spawn(work)).collect();
        let mut done = work();
        for h in workers {
            done.extend(h.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)));
        }
        done
    });
    done.sort_by_key(|(i, _)| *i);
    done.into_iter().map(|(_, r)| r).collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_item_is_mapped_in_its_order() {
        let items: Vec<u64> = (0..1000).collect();
        assert_eq!(super::parallel_map(&items, |x| x * x), items.iter().map(|x| x * x).collect::<Vec<_>>());
        assert!(super::parallel_map(&[] as &[u64], |x| *x).is_empty());
        // One item: mapped on the calling thread.
        let caller = std::thread::current().id();
        assert_eq!(super::parallel_map(&[7u64], |x| (x + 1, std::thread::current().id() == caller)), vec![(8, true)]);
    }

    /// Marks that an item ran on the calling thread or elsewhere, then waits (up to 5 s)
    /// until items have run on both: whichever thread takes the first item cannot take them
    /// all, so the test does not rest on which thread starts first.
    fn mark_and_wait_for_both(caller: std::thread::ThreadId, seen: &[std::sync::atomic::AtomicBool; 2]) -> bool {
        use std::sync::atomic::Ordering::SeqCst;
        let here = std::thread::current().id() == caller;
        seen[usize::from(here)].store(true, SeqCst);
        let start = std::time::Instant::now();
        while !(seen[0].load(SeqCst) && seen[1].load(SeqCst)) && start.elapsed() < std::time::Duration::from_secs(5) {
            std::thread::yield_now();
        }
        here
    }

    #[test]
    fn the_calling_thread_works_and_a_panic_on_any_worker_is_passed_on() {
        if super::cores() < 2 {
            return;
        }
        let caller = std::thread::current().id();
        let seen = Default::default();
        let on_caller: Vec<bool> = super::parallel_map(&[0u64; 8], |_| mark_and_wait_for_both(caller, &seen));
        assert!(on_caller.contains(&true) && on_caller.contains(&false), "{on_caller:?}");
        // A panic is passed on whichever thread it happens on.
        for on_the_caller in [true, false] {
            let seen: [std::sync::atomic::AtomicBool; 2] = Default::default();
            let panicked = std::panic::catch_unwind(|| {
                super::parallel_map(&[0u64; 8], |_| {
                    let here = std::thread::current().id() == caller;
                    if here == on_the_caller {
                        seen[usize::from(here)].store(true, std::sync::atomic::Ordering::SeqCst);
                        panic!("a cause's bug");
                    }
                    mark_and_wait_for_both(caller, &seen);
                })
            });
            assert!(panicked.is_err(), "on the caller: {on_the_caller}");
        }
    }
}
