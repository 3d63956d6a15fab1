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
}
