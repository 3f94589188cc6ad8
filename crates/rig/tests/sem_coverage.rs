//! The contract's coverage of the σ of the mean (`docs/REFERENCE.md` → `docs/CALIBRATE.md`,
//! "The contract's coverage table": what 'covers' means on short drifting sequences), cell by cell.
//!
//! Model of one tangent axis: `x_t = √s·a_t + √(1 − s)·e_t`, `a` a stationary unit AR(1) with
//! coefficient ρ, `e` unit white noise, s the drift share; true mean 0, true
//! `n·Var(x̄) = s·τ(ρ) + 1 − s`. Each sequence has six independent axes; the rule
//! ([`crashrig_rig::sem::SemModel::estimate`]) sees their residuals about the sequence mean and
//! their covariance, exactly as `calibrate` does. Per cell of {ρ 0, 0.5, 0.9, 0.95} ×
//! {s 0, ¼, ½, 1} × {n 60, 140, 300}, over all 6 × `sequences` intervals:
//! - **plain**: x̄ ± 2 SE covers 0;
//! - **A**, refusals counted as covered: covered or `reliable = false`;
//! - **B**, refusals counted as misses: covered and `reliable = true`;
//! - **refused**: share with `reliable = false`;
//! - **SE/true**: the mean over the cell's sequences of SE / true SE, axis by axis, and of
//!   the six axes the highest (the acceptance's statistic: one axis's mean over sequences).
//!
//! The contract per cell: A ≥ 90 %; refused ≤ 50 % where the true effective n
//! (`n / f`, `f = n·Var(x̄)/E[s²]`) is ≥ 10, ≤ 10 % on white noise (ρ = 0 or s = 0); B ≥ 85 %
//! where n ≥ 140; on white noise plain and A ≤ 99.5 % and SE/true ≤ 1.5.
//!
//! `sem_coverage_contract_grid_slow` computes every cell (4000 sequences per cell at n = 60,
//! 2000 at n = 140, 1000 at n = 300: 24 000 / 12 000 / 6 000 independent intervals, binomial
//! SE of a share near 90 % 0.19 / 0.27 / 0.39 points, near 85 % 0.23 / 0.33 / 0.46) and
//! prints the markdown table of docs/CALIBRATE.md; with `CRASHRIG_WRITE_SEM_TABLE=1` it also
//! writes it into docs/CALIBRATE.md between the `sem-coverage-table` markers:
//!
//! ```sh
//! CRASHRIG_WRITE_SEM_TABLE=1 cargo test --release -p crashrig-rig --test tests \
//!     -- --ignored sem_coverage_contract_grid_slow --nocapture
//! ```

use crashrig_geometry::{Mat6, Vec6};
use crashrig_rig::sem::{SemModel, ar1_tau};
use rand_distr::StandardNormal;
use rayon::prelude::*;

const RHOS: [f64; 4] = [0.0, 0.5, 0.9, 0.95];
const SHARES: [f64; 4] = [0.0, 0.25, 0.5, 1.0];
const NS: [usize; 3] = [60, 140, 300];

/// One sequence's six axes: residuals `√s·a_t + √(1 − s)·e_t` (stream `rep` of `seed`).
fn mixture(seed: u64, rep: u64, n: usize, rho: f64, share: f64) -> Vec<Vec6> {
    use rand::RngExt;
    let mut rng = crashrig_stats::stream(seed, rep);
    let mut g = || -> f64 { rng.sample(StandardNormal) };
    let mut a = Vec6::from_fn(|_, _| g());
    let innovation = (1.0 - rho * rho).sqrt();
    (0..n)
        .map(|i| {
            if i > 0 {
                a = a * rho + Vec6::from_fn(|_, _| g()) * innovation;
            }
            a * share.sqrt() + Vec6::from_fn(|_, _| g()) * (1.0 - share).sqrt()
        })
        .collect()
}

/// The counts of one cell.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Tally {
    intervals: usize,
    covered: usize,
    refused: usize,
    covered_or_refused: usize,
    covered_and_reliable: usize,
    /// Per axis, the sum over sequences of SE / true SE.
    se_over_true: [f64; 6],
}

impl Tally {
    fn add(mut self, o: Tally) -> Tally {
        self.intervals += o.intervals;
        self.covered += o.covered;
        self.refused += o.refused;
        self.covered_or_refused += o.covered_or_refused;
        self.covered_and_reliable += o.covered_and_reliable;
        for (a, b) in self.se_over_true.iter_mut().zip(o.se_over_true) {
            *a += b;
        }
        self
    }
    fn share(&self, k: usize) -> f64 {
        k as f64 / self.intervals as f64
    }
    fn plain(&self) -> f64 {
        self.share(self.covered)
    }
    fn a(&self) -> f64 {
        self.share(self.covered_or_refused)
    }
    fn b(&self) -> f64 {
        self.share(self.covered_and_reliable)
    }
    fn refused_share(&self) -> f64 {
        self.share(self.refused)
    }
    /// The mean of SE / true SE over all intervals of the cell (the six axes pooled).
    fn mean_ratio(&self) -> f64 {
        self.se_over_true.iter().sum::<f64>() / self.intervals as f64
    }
    /// The highest over the six axes of the mean over sequences of SE / true SE.
    fn ratio(&self) -> f64 {
        let sequences = (self.intervals / 6) as f64;
        self.se_over_true
            .iter()
            .map(|s| s / sequences)
            .fold(f64::MIN, f64::max)
    }
}

/// `(true SE, true effective n)` of a cell: `√((sτ + 1 − s)/n)` and `n / f`,
/// `f = (sτ + 1 − s) / E[s²]`, `E[s²] = s(1 − τ/n)·n/(n − 1) + 1 − s`.
fn truth(n: usize, rho: f64, share: f64) -> (f64, f64) {
    let (nf, tau) = (n as f64, ar1_tau(n, rho));
    let n_var = share * tau + 1.0 - share;
    let expected_s2 = share * (1.0 - tau / nf) * nf / (nf - 1.0) + 1.0 - share;
    ((n_var / nf).sqrt(), nf * expected_s2 / n_var)
}

/// One sequence through the rule.
fn one(model: &SemModel, seed: u64, rep: u64, n: usize, rho: f64, share: f64) -> Tally {
    let x = mixture(seed, rep, n, rho, share);
    let mean = x.iter().sum::<Vec6>() / n as f64;
    let r: Vec<Vec6> = x.iter().map(|v| v - mean).collect();
    let cov = r.iter().map(|v| v * v.transpose()).sum::<Mat6>() / (n as f64 - 1.0);
    let s = model.estimate(&r, &cov);
    let true_se = truth(n, rho, share).0;
    let mut t = Tally {
        intervals: 6,
        ..Tally::default()
    };
    for j in 0..6 {
        let se = s.covariance[(j, j)].sqrt();
        let covered = mean[j].abs() <= 2.0 * se;
        t.covered += usize::from(covered);
        t.refused += usize::from(!s.reliable[j]);
        t.covered_or_refused += usize::from(covered || !s.reliable[j]);
        t.covered_and_reliable += usize::from(covered && s.reliable[j]);
        t.se_over_true[j] = se / true_se;
    }
    t
}

/// `sequences` sequences of one cell (in parallel; summed in sequence order, so the result
/// does not depend on the thread count).
fn cell(seed: u64, sequences: u64, n: usize, rho: f64, share: f64) -> Tally {
    let model = SemModel::new(n);
    let per: Vec<Tally> = (0..sequences)
        .into_par_iter()
        .map(|rep| one(&model, seed, rep, n, rho, share))
        .collect();
    per.into_iter().fold(Tally::default(), Tally::add)
}

/// The contract's bounds that `t` breaks in cell (ρ, s, n), as text (empty: all hold).
fn violations(rho: f64, share: f64, n: usize, t: &Tally) -> Vec<String> {
    let white = rho == 0.0 || share == 0.0;
    let eff_n = truth(n, rho, share).1;
    let mut v = Vec::new();
    let mut check = |ok: bool, what: String| {
        if !ok {
            v.push(format!("ρ {rho} s {share} n {n}: {what}"));
        }
    };
    check(t.a() >= 0.90, format!("A {:.4} < 0.90", t.a()));
    if eff_n >= 10.0 {
        let cap = if white { 0.10 } else { 0.50 };
        check(
            t.refused_share() <= cap,
            format!("refused {:.4} > {cap}", t.refused_share()),
        );
    }
    if n >= 140 {
        check(t.b() >= 0.85, format!("B {:.4} < 0.85", t.b()));
    }
    if white {
        check(t.a() <= 0.995, format!("A {:.4} > 0.995", t.a()));
        check(
            t.plain() <= 0.995,
            format!("plain {:.4} > 0.995", t.plain()),
        );
        check(t.ratio() <= 1.5, format!("SE/true {:.3} > 1.5", t.ratio()));
    }
    v
}

fn pct(x: f64) -> String {
    format!("{:.1}", 100.0 * x)
}

/// The markdown table of docs/CALIBRATE.md from the 48 cells (in grid order).
fn markdown(cells: &[((f64, f64, usize), u64, Tally)]) -> String {
    let mut s = String::from(
        "| ρ | drift share | n | true effective n | sequences | ±2 SE covers | refusals as covered (A) | refusals as misses (B) | refused | mean SE / true SE (highest axis) | contract |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for &((rho, share, n), seqs, t) in cells {
        let mark = if violations(rho, share, n, &t).is_empty() {
            "met"
        } else {
            "**FAILS**"
        };
        s.push_str(&format!(
            "| {rho} | {share} | {n} | {:.1} | {seqs} | {} % | {} % | {} % | {} % | {:.2} | {mark} |\n",
            truth(n, rho, share).1,
            pct(t.plain()),
            pct(t.a()),
            pct(t.b()),
            pct(t.refused_share()),
            t.ratio(),
        ));
    }
    let white = |c: &(f64, f64, usize)| c.0 == 0.0 || c.1 == 0.0;
    let worst =
        |f: &dyn Fn(&Tally) -> f64, keep: &dyn Fn(&(f64, f64, usize)) -> bool, max: bool| {
            let it = cells.iter().filter(|c| keep(&c.0)).map(|c| f(&c.2));
            if max {
                it.fold(f64::MIN, f64::max)
            } else {
                it.fold(f64::MAX, f64::min)
            }
        };
    s.push_str(&format!(
        "\nLowest A over all cells {} %; lowest B over the cells with n ≥ 140 {} %; most refused \
         where the true effective n ≥ 10 and the drift is real {} %; white noise (ρ = 0 or s = 0): \
         most refused {} %, highest coverage {} %, highest mean SE / true SE of an axis {:.2}.\n",
        pct(worst(&Tally::a, &|_| true, false)),
        pct(worst(&Tally::b, &|c| c.2 >= 140, false)),
        pct(worst(
            &Tally::refused_share,
            &|c| !white(c) && truth(c.2, c.0, c.1).1 >= 10.0,
            true
        )),
        pct(worst(&Tally::refused_share, &white, true)),
        pct(worst(&Tally::a, &white, true)),
        worst(&Tally::ratio, &white, true),
    ));
    s
}

/// Sequences per cell: more where n is small (cheap, and where the bounds are closest).
fn sequences_for(n: usize) -> u64 {
    match n {
        60 => 4000,
        140 => 2000,
        _ => 1000,
    }
}

#[test]
#[ignore = "slow: the contract's 48-cell coverage grid, 1000–4000 sequences × 6 axes per cell"]
fn sem_coverage_contract_grid_slow() {
    let start = std::time::Instant::now();
    let mut cells = Vec::new();
    let mut index = 0u64;
    for rho in RHOS {
        for share in SHARES {
            for n in NS {
                let seqs = sequences_for(n);
                let t = cell(3600 + index, seqs, n, rho, share);
                index += 1;
                eprintln!(
                    "ρ {rho} s {share} n {n}: plain {} A {} B {} refused {} SE/true {:.3} ({:.0} s)",
                    pct(t.plain()),
                    pct(t.a()),
                    pct(t.b()),
                    pct(t.refused_share()),
                    t.ratio(),
                    start.elapsed().as_secs_f64()
                );
                cells.push(((rho, share, n), seqs, t));
            }
        }
    }
    let table = markdown(&cells);
    eprintln!("{table}");
    if std::env::var_os("CRASHRIG_WRITE_SEM_TABLE").is_some() {
        write_into_doc(&table);
    }
    let broken: Vec<String> = cells
        .iter()
        .flat_map(|&((rho, share, n), _, t)| violations(rho, share, n, &t))
        .collect();
    eprintln!("grid: {:.0} s", start.elapsed().as_secs_f64());
    assert!(broken.is_empty(), "contract bounds broken: {broken:#?}");
}

/// Replaces the text between `<!-- sem-coverage-table:begin -->` and
/// `<!-- sem-coverage-table:end -->` in docs/CALIBRATE.md.
fn write_into_doc(table: &str) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/CALIBRATE.md");
    let doc = std::fs::read_to_string(&path).unwrap();
    let (begin, end) = (
        "<!-- sem-coverage-table:begin -->\n",
        "<!-- sem-coverage-table:end -->",
    );
    let (i, j) = (
        doc.find(begin).unwrap() + begin.len(),
        doc.find(end).unwrap(),
    );
    let new = format!("{}{table}{}", &doc[..i], &doc[j..]);
    std::fs::write(&path, new).unwrap();
}

#[test]
fn sem_coverage_key_cells_fast() {
    // Four key cells, 150 sequences × 6 axes = 900 intervals each (fixed seeds); the slow
    // grid measures them on 12 000–24 000 intervals (docs/CALIBRATE.md). Binomial SE over 900
    // intervals: 1.0 point near 90 %, 0.6 near 96 %.
    //
    // (ρ 0.95, s ¼, n 140), the issue's case: the former rule `ar1_noise_fit` covered 86.7 %
    // and refused 39 %, so B was 49 %. This rule: B ≈ 90 % (slow grid: 89.8 %, the lowest B
    // of the grid; the pooled step refuses 6 % there); ≥ 86 % is 4 SE below.
    let t = cell(36, 150, 140, 0.95, 0.25);
    assert!(t.b() >= 0.86, "(0.95, ¼, 140): {t:?}");
    // (ρ 0.95, s 1, n 140), true effective n 3.2: the former rule refused 88 % (B 7.5 %); this
    // one resolves the drift and covers: B ≈ 98 % (slow grid), ≥ 93 % is more than 4 SE
    // (0.5 points each) below.
    let t = cell(37, 150, 140, 0.95, 1.0);
    assert!(t.b() >= 0.93, "(0.95, 1, 140): {t:?}");
    // (ρ 0.95, s ½, n 140), issue 25's case (the lag-1 rule covered 49.5 %, `ar1_noise_fit`
    // 86.5 %): ±2 SE covers ≈ 98 % (slow grid); ≥ 93 % is more than 4 SE below.
    let t = cell(39, 150, 140, 0.95, 0.5);
    assert!(t.plain() >= 0.93, "(0.95, ½, 140): {t:?}");
    // White noise, n = 60: honest and rarely refused. Mean SE/true over the six axes ≈ 1.22
    // (its standard deviation over intervals is about 1.3, so the mean of 900 is within ±0.09
    // at 2 SE; one axis's mean over 150 sequences scatters more: the per-axis statistic of the
    // contract is `sem_white_noise_mean_se_per_axis_within_contract`'s); refusals ≈ 1 % (≤ 6 %
    // is 4 SE above); coverage 93–99.5 %.
    let t = cell(38, 150, 60, 0.0, 0.0);
    assert!(t.mean_ratio() <= 1.5, "white noise 60: {t:?}");
    assert!(t.refused_share() <= 0.06, "white noise 60: {t:?}");
    assert!((0.93..=0.995).contains(&t.plain()), "white noise 60: {t:?}");
}

/// Per axis, the mean over `sequences` white-noise sequences (independent N(0, 1) epoch
/// errors on six axes, stream `rep` of `seed`) of the printed SE over the true SE `1/√n`, and
/// the standard deviation of that ratio over the sequences.
fn white_noise_ratio_per_axis(seed: u64, sequences: u64, n: usize) -> [(f64, f64); 6] {
    let model = SemModel::new(n);
    let per: Vec<[f64; 6]> = (0..sequences)
        .into_par_iter()
        .map(|rep| one(&model, seed, rep, n, 0.0, 0.0).se_over_true)
        .collect();
    let m = sequences as f64;
    std::array::from_fn(|j| {
        let mean = per.iter().map(|r| r[j]).sum::<f64>() / m;
        let var = per.iter().map(|r| (r[j] - mean).powi(2)).sum::<f64>() / (m - 1.0);
        (mean, var.sqrt())
    })
}

#[test]
fn sem_white_noise_mean_se_per_axis_within_contract() {
    // The acceptance's statistic (issue 47 item 5): 200 sequences of independent Gaussian
    // epoch errors, no drift; per axis, the mean over the sequences of the printed SE (F·q and
    // every widening included) over the true SE σ/√n. The contract allows ≤ 1.5 on every axis.
    // The ratio is heavy-tailed (the few white axes whose drift fit or test fires carry several
    // σ/√n; its standard deviation over sequences is 0.9–1.6), so one 200-sequence mean has a
    // standard error of 0.06–0.12 (printed). Asserted, on two independent 200-sequence samples
    // per n: every axis's mean ≤ 1.5, and the mean over the 2 × 6 axes ≤ 1.30 at n = 60 and
    // ≤ 1.25 at n = 140 — the rule's expected value (1.22 and 1.17 over 30 samples) with
    // 4 standard errors of that 2400-interval mean to spare, and 3 standard errors of one
    // 200-sequence mean below the contract. With SEM_DRIFT_PENALTY 1 (the rule before) the
    // expected value was 1.41 and 1.29 and one axis of a 200-sequence sample reached 1.68.
    for (n, cap) in [(60usize, 1.30), (140, 1.25)] {
        let mut sum = 0.0;
        for seed in [4700u64, 4701] {
            let axes = white_noise_ratio_per_axis(seed, 200, n);
            let (top, sd) = axes
                .iter()
                .copied()
                .fold((0.0f64, 0.0f64), |a, b| if b.0 > a.0 { b } else { a });
            eprintln!(
                "white noise n {n} seed {seed}: mean SE / true SE per axis {:.3?}; highest {top:.3} \
                 (its SE over 200 sequences {:.3})",
                axes.map(|a| a.0),
                sd / 200f64.sqrt()
            );
            assert!(top <= 1.5, "n {n} seed {seed}: {axes:?}");
            sum += axes.iter().map(|a| a.0).sum::<f64>();
        }
        let mean = sum / 12.0;
        eprintln!("white noise n {n}: mean over the 12 per-axis means {mean:.3}");
        assert!(mean <= cap, "n {n}: mean SE / true SE {mean:.3} > {cap}");
    }
}
