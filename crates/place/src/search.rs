//! The search over layouts on the first-order [`Table`]: every K-subset when there are at
//! most [`crate::EXHAUSTIVE_MAX_LAYOUTS`] of them, else greedy forward selection with
//! best-improvement swap refinement. Memory is independent of the number of subsets: the
//! search keeps only a bounded [`Board`] of the best distinct layouts it has scored.

use crate::approx::{Score, Table};
use rayon::prelude::*;
use std::cmp::Ordering;
use std::ops::Range;

/// The best distinct K-layouts scored so far (candidate indices, sorted), best first; ties
/// by the lexicographically smaller set, so the board does not depend on the evaluation order.
#[derive(Debug, Clone)]
pub struct Board {
    cap: usize,
    /// (score, layout) best first.
    pub entries: Vec<(Score, Vec<usize>)>,
}

fn rank(a: &(Score, Vec<usize>), b: &(Score, Vec<usize>)) -> Ordering {
    // Ordering::Less = `a` ranks first.
    b.0.compare(&a.0).then_with(|| a.1.cmp(&b.1))
}

impl Board {
    /// An empty board keeping `cap` layouts.
    pub fn new(cap: usize) -> Self {
        Board {
            cap,
            entries: Vec::with_capacity(cap + 1),
        }
    }

    /// Offers a layout (any order of indices).
    pub fn offer(&mut self, score: Score, layout: &[usize]) {
        let mut set = layout.to_vec();
        set.sort_unstable();
        if self.entries.iter().any(|(_, s)| *s == set) {
            return;
        }
        let e = (score, set);
        if self.entries.len() == self.cap
            && self
                .entries
                .last()
                .is_some_and(|last| rank(&e, last) != Ordering::Less)
        {
            return;
        }
        let at = self
            .entries
            .partition_point(|x| rank(x, &e) == Ordering::Less);
        self.entries.insert(at, e);
        self.entries.truncate(self.cap);
    }

    /// The board of both boards' layouts.
    pub fn merge(mut self, other: Board) -> Board {
        for (s, l) in other.entries {
            self.offer(s, &l);
        }
        self
    }
}

/// [`Found::method`] of the search over every subset.
pub const EXHAUSTIVE: &str = "exhaustive";
/// [`Found::method`] of greedy forward selection with swap refinement.
pub const GREEDY_SWAP: &str = "greedy+swap";

/// What the search found.
#[derive(Debug, Clone)]
pub struct Found {
    /// `"exhaustive"` or `"greedy+swap"`.
    pub method: &'static str,
    /// Layouts scored by the approximation during the search (the greedy steps' partial
    /// layouts included; exactly C(n, K) for the exhaustive search).
    pub evaluated: u64,
    /// The best layouts, best first.
    pub board: Board,
}

/// C(n, k), saturating.
pub fn binomial(n: usize, k: usize) -> u128 {
    if k > n {
        return 0;
    }
    let k = k.min(n - k);
    let mut c: u128 = 1;
    for i in 0..k {
        c = c.saturating_mul((n - i) as u128) / (i + 1) as u128;
    }
    c
}

/// Searches the K-layouts of `table`'s candidates; `keep` layouts are kept on the board.
/// The whole search is the share of every item ([`search_share`]): one enumerator of the
/// subsets serves both.
pub fn search(table: &Table, k: usize, keep: usize) -> Found {
    search_share(table, k, keep, 0..items(table.candidates(), k))
}

/// The work items of a sharded search: the C(n, K) subsets in lexicographic order when the
/// search is exhaustive, else 1 (greedy + swap is one sequential search that cannot be split).
pub fn items(n: usize, k: usize) -> usize {
    let c = binomial(n, k);
    if c <= crate::EXHAUSTIVE_MAX_LAYOUTS as u128 {
        c as usize
    } else {
        1
    }
}

/// The share `ranks` of the search of [`items`]: the subsets of those lexicographic ranks
/// (exhaustive), or the whole greedy + swap search when `ranks` holds its one item (else
/// nothing). The board holds the best `keep` layouts of the share; the best `keep` layouts of
/// the union of all shares' boards are the unsharded search's (the board's order is total).
pub fn search_share(table: &Table, k: usize, keep: usize, ranks: Range<usize>) -> Found {
    let n = table.candidates();
    let before = table.scored();
    let mut found = if binomial(n, k) <= crate::EXHAUSTIVE_MAX_LAYOUTS as u128 {
        exhaustive_ranks(table, k, keep, ranks)
    } else if ranks.is_empty() {
        Found {
            method: GREEDY_SWAP,
            evaluated: 0,
            board: Board::new(keep),
        }
    } else {
        greedy_swap(table, k, keep)
    };
    found.evaluated = table.scored() - before;
    found
}

/// The K-subset of `0..n` with lexicographic rank `r` (`r < C(n, K)`).
pub fn unrank(n: usize, k: usize, mut r: u128) -> Vec<usize> {
    let mut out = Vec::with_capacity(k);
    let mut x = 0;
    for i in 0..k {
        loop {
            let with_x = binomial(n - x - 1, k - i - 1);
            if r < with_x {
                out.push(x);
                x += 1;
                break;
            }
            r -= with_x;
            x += 1;
        }
    }
    out
}

/// The lexicographic successor of `layout` among the K-subsets of `0..n`; false after the last.
fn next_subset(layout: &mut [usize], n: usize) -> bool {
    let k = layout.len();
    let mut i = k;
    while i > 0 {
        i -= 1;
        if layout[i] < n - k + i {
            layout[i] += 1;
            for j in i + 1..k {
                layout[j] = layout[j - 1] + 1;
            }
            return true;
        }
    }
    false
}

/// The subsets of lexicographic ranks `ranks`, in parallel chunks (boards merged; the result
/// does not depend on the chunking).
fn exhaustive_ranks(table: &Table, k: usize, keep: usize, ranks: Range<usize>) -> Found {
    let n = table.candidates();
    const CHUNK: usize = 512;
    let starts: Vec<usize> = ranks.clone().step_by(CHUNK).collect();
    let board = starts
        .into_par_iter()
        .map(|start| {
            let end = (start + CHUNK).min(ranks.end);
            let mut board = Board::new(keep);
            let mut dirs = Vec::new();
            let mut layout = unrank(n, k, start as u128);
            for r in start..end {
                board.offer(table.score(&layout, &mut dirs), &layout);
                if r + 1 < end && !next_subset(&mut layout, n) {
                    break;
                }
            }
            board
        })
        .collect::<Vec<_>>()
        .into_iter()
        .fold(Board::new(keep), |acc, b| acc.merge(b));
    Found {
        method: EXHAUSTIVE,
        evaluated: 0,
        board,
    }
}

/// The best of `options` (layouts), each scored in parallel; ties by the earlier option.
fn best_of(table: &Table, options: Vec<Vec<usize>>) -> Vec<(Score, Vec<usize>)> {
    options
        .into_par_iter()
        .map_init(Vec::new, |dirs, l| (table.score(&l, dirs), l))
        .collect()
}

fn pick(scored: &[(Score, Vec<usize>)]) -> Option<usize> {
    let mut best: Option<usize> = None;
    for (i, s) in scored.iter().enumerate() {
        if best.is_none_or(|b| s.0.compare(&scored[b].0) == Ordering::Greater) {
            best = Some(i);
        }
    }
    best
}

/// Greedy forward selection (from the best pair when the base layout has no σ anywhere, i.e.
/// single additions cannot be told apart), then best-improvement swaps (one chosen for one
/// unchosen) until none improves the score.
fn greedy_swap(table: &Table, k: usize, keep: usize) -> Found {
    let n = table.candidates();
    let mut board = Board::new(keep);
    let offer = |board: &mut Board, scored: &[(Score, Vec<usize>)]| {
        for (s, l) in scored {
            if l.len() == k {
                board.offer(*s, l);
            }
        }
    };
    // The best one (or the best pair, when single candidates cannot be told apart); then
    // forward selection.
    let mut current = order_within(table, &(0..n).collect::<Vec<_>>(), k.min(2));
    while current.len() < k {
        let options: Vec<Vec<usize>> = (0..n)
            .filter(|c| !current.contains(c))
            .map(|c| {
                let mut l = current.clone();
                l.push(c);
                l
            })
            .collect();
        let scored = best_of(table, options);
        offer(&mut board, &scored);
        let Some(i) = pick(&scored) else { break };
        current = scored[i].1.clone();
    }
    let mut dirs = Vec::new();
    let mut score = table.score(&current, &mut dirs);
    board.offer(score, &current);
    for _round in 0..MAX_SWAP_ROUNDS {
        let mut options = Vec::new();
        for i in 0..current.len() {
            for c in (0..n).filter(|c| !current.contains(c)) {
                let mut l = current.clone();
                l[i] = c;
                options.push(l);
            }
        }
        let scored = best_of(table, options);
        offer(&mut board, &scored);
        match pick(&scored) {
            Some(i) if scored[i].0.compare(&score) == Ordering::Greater => {
                score = scored[i].0;
                current = scored[i].1.clone();
            }
            _ => break,
        }
    }
    Found {
        method: GREEDY_SWAP,
        evaluated: 0,
        board,
    }
}

/// Upper bound of swap rounds (each strictly improves the score, so the search ends anyway).
const MAX_SWAP_ROUNDS: usize = 1000;

/// The pick order of `set` (candidate indices): greedily, the member that improves the
/// approximate score most comes next (ties: file order); the first two come as the best pair
/// when single members cannot be told apart (every score equal). Returns the first `take`
/// (all when `take ≥ set.len()`).
pub fn order_within(table: &Table, set: &[usize], take: usize) -> Vec<usize> {
    let mut set = set.to_vec();
    set.sort_unstable();
    let mut dirs = Vec::new();
    let mut chosen: Vec<usize> = Vec::new();
    let take = take.min(set.len());
    while chosen.len() < take {
        let rest: Vec<usize> = set
            .iter()
            .copied()
            .filter(|c| !chosen.contains(c))
            .collect();
        let scored: Vec<(Score, Vec<usize>)> = rest
            .iter()
            .map(|&c| {
                let mut l = chosen.clone();
                l.push(c);
                (table.score(&l, &mut dirs), l)
            })
            .collect();
        let all_equal = scored
            .windows(2)
            .all(|w| w[0].0.compare(&w[1].0) == Ordering::Equal);
        if all_equal && rest.len() >= 2 && chosen.len() + 2 <= take {
            // Pairs decide (e.g. no observer of its own: one camera alone measures nothing).
            let mut best: Option<(Score, Vec<usize>)> = None;
            for (i, &a) in rest.iter().enumerate() {
                for &b in &rest[i + 1..] {
                    let mut l = chosen.clone();
                    l.extend([a, b]);
                    let s = table.score(&l, &mut dirs);
                    if best
                        .as_ref()
                        .is_none_or(|(bs, _)| s.compare(bs) == Ordering::Greater)
                    {
                        best = Some((s, l));
                    }
                }
            }
            if let Some((_, l)) = best {
                chosen = l;
                continue;
            }
        }
        let Some(i) = pick(&scored) else { break };
        chosen = scored[i].1.clone();
    }
    chosen.truncate(take);
    chosen
}
