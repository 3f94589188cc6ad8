//! The placement search against independent answers: the first-order terms against `grid`'s own
//! first-order map (the same model, another code path) and against the Monte Carlo; the search
//! against the exhaustive Monte Carlo optimum on the bundled 8-candidate example.

use crashrig_mc::{GridStudy, Observer, Scenario, read_candidates};
use crashrig_place::approx::{Score, Table};
use crashrig_place::{PlaceConfig, layout, monte_carlo_score, search};
use std::path::{Path, PathBuf};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/place")
        .join(name)
}

fn inputs() -> (Scenario, Vec<Observer>) {
    let s = Scenario::from_path_for_placement(&example("scenario.toml")).unwrap();
    let c = read_candidates(&example("candidates.toml"), &s).unwrap();
    (s, c)
}

/// The table over every candidate (base = the scenario's own observers).
fn table(s: &Scenario, c: &[Observer]) -> Table {
    let all = layout(s, c);
    let study = GridStudy::new(&all, 100, 1).unwrap();
    let base = s.grid.as_ref().unwrap().observers.len();
    Table::build(&study, base, None).unwrap()
}

/// For several layouts: the σ_max of the summed terms equals `grid`'s first-order σ_max
/// (`PointStats::linear_sigma_max_mm`, computed by the aimed path's Jacobian for aimed-only
/// layouts and the fixed path's for mixed ones) to 1e-9 relative — the same formula, so only
/// rounding may differ — and blanks exactly the points `grid` blanks.
#[test]
fn terms_reproduce_the_grid_first_order_map() {
    let (s, c) = inputs();
    let t = table(&s, &c);
    let mut dirs = Vec::new();
    for chosen in [vec![0, 1], vec![2, 4, 5], vec![6, 7], vec![0, 3, 6]] {
        let obs: Vec<Observer> = chosen.iter().map(|&i| c[i].clone()).collect();
        let l = layout(&s, &obs);
        let study = GridStudy::new(&l, 64, 1).unwrap();
        let mut r = study
            .run(&crashrig_mc::RunOptions::samples(64, 1), None)
            .unwrap();
        crashrig_mc::degenerate::mask_degenerate(&mut r, study.grid());
        for (p, stats) in r.points.iter().enumerate() {
            let ours = t.sigma_max(p, &chosen, &mut dirs);
            let theirs = stats.linear_sigma_max_mm();
            match ours {
                Some(v) => {
                    assert!(
                        (v / theirs - 1.0).abs() < 1e-9,
                        "layout {chosen:?} point {p}: {v} vs grid {theirs}"
                    );
                    assert!(stats.sigma_max_mm.is_finite());
                }
                None => assert!(
                    !stats.sigma_max_mm.is_finite(),
                    "layout {chosen:?} point {p}: grid has σ {} where the search has none",
                    stats.sigma_max_mm
                ),
            }
        }
    }
}

/// The approximation against the Monte Carlo (4000 draws) per point: within 6 %. The Monte
/// Carlo σ of one axis has a relative standard error of 1/√(2·3999) ≈ 1.1 %, so 6 % is 5.4
/// standard errors (σ_max is a max of three such σ); the observers' pose σ (≤ 2.6 mm, 0.024°)
/// and pixel σ are small against the 0.4–2 m distances, so the first-order term is the model's
/// whole story up to well below 1 % — a bigger gap would mean the terms are wrong.
#[test]
fn first_order_sigma_agrees_with_the_monte_carlo() {
    let (s, c) = inputs();
    let t = table(&s, &c);
    let mut dirs = Vec::new();
    for chosen in [vec![0, 1], vec![2, 5], vec![0, 6, 7]] {
        let obs: Vec<Observer> = chosen.iter().map(|&i| c[i].clone()).collect();
        let l = layout(&s, &obs);
        let study = GridStudy::new(&l, 4000, 11).unwrap();
        let mut r = study
            .run(&crashrig_mc::RunOptions::samples(4000, 11), None)
            .unwrap();
        crashrig_mc::degenerate::mask_degenerate(&mut r, study.grid());
        let mut compared = 0;
        for (p, stats) in r.points.iter().enumerate() {
            if let Some(v) = t.sigma_max(p, &chosen, &mut dirs) {
                let mc = stats.sigma_max_mm;
                assert!(
                    (mc / v - 1.0).abs() < 0.06,
                    "layout {chosen:?} point {p}: Monte Carlo {mc} vs first order {v}"
                );
                compared += 1;
            }
        }
        assert!(
            compared > 100,
            "layout {chosen:?}: only {compared} points compared"
        );
    }
}

/// The search's evaluated count and board: exhaustive scores each of C(8, K) layouts exactly
/// once and its board's best is the best of all subsets scored one by one.
#[test]
fn exhaustive_search_scores_every_subset_once() {
    let (s, c) = inputs();
    let t = table(&s, &c);
    for k in 1..=3 {
        let found = search::search(&t, k, 4);
        assert_eq!(found.method, "exhaustive");
        assert_eq!(found.evaluated as u128, search::binomial(8, k));
        let mut dirs = Vec::new();
        let mut best: Option<Score> = None;
        let mut subsets = vec![vec![]];
        for i in 0..8 {
            let more: Vec<Vec<usize>> = subsets
                .iter()
                .filter(|s| s.len() < k)
                .map(|s| {
                    let mut s = s.clone();
                    s.push(i);
                    s
                })
                .collect();
            subsets.extend(more);
        }
        for l in subsets.iter().filter(|l| l.len() == k) {
            let sc = t.score(l, &mut dirs);
            if best.is_none_or(|b| sc.compare(&b) == std::cmp::Ordering::Greater) {
                best = Some(sc);
            }
        }
        assert_eq!(found.board.entries[0].0, best.unwrap(), "K = {k}");
        assert!(found.board.entries.len() <= 4);
    }
}

/// The contract's test: the chosen layout's confirmed share is within 0.02 of the best subset's
/// Monte Carlo share, the best found by running the Monte Carlo on every subset (8 candidates,
/// K = 2: 28 layouts; same draws and seed as the run).
#[test]
fn chosen_layout_is_within_002_of_the_monte_carlo_optimum_k2() {
    check_against_exhaustive_monte_carlo(2, 400);
}

/// As the K = 2 test, for K = 3 (56 layouts; slow in debug mode).
#[test]
#[ignore = "slow: 56 Monte Carlo grids; run by cargo xtask test --slow"]
fn chosen_layout_is_within_002_of_the_monte_carlo_optimum_k3() {
    check_against_exhaustive_monte_carlo(3, 2000);
}

fn check_against_exhaustive_monte_carlo(k: usize, samples: usize) {
    let (s, c) = inputs();
    let dir = tempfile::tempdir().unwrap();
    let config = PlaceConfig {
        scenario: example("scenario.toml"),
        candidates: example("candidates.toml"),
        choose: k,
        out: dir.path().join("out"),
        samples: Some(samples),
        seed: Some(5),
        plots: false,
    };
    let run = crashrig_place::run(&config, None).unwrap();
    let mut best = 0.0f64;
    let mut stack: Vec<Vec<usize>> = (0..c.len()).map(|i| vec![i]).collect();
    while let Some(l) = stack.pop() {
        if l.len() == k {
            let obs: Vec<Observer> = l.iter().map(|&i| c[i].clone()).collect();
            let sc = monte_carlo_score(&layout(&s, &obs), samples, 5, None, "").unwrap();
            best = best.max(sc.share());
            continue;
        }
        for i in l[l.len() - 1] + 1..c.len() {
            let mut m = l.clone();
            m.push(i);
            stack.push(m);
        }
    }
    let got = run.placement.share_below_threshold;
    assert!(
        got >= best - 0.02,
        "K = {k}: chosen {:?} confirmed share {got}, best subset {best}",
        run.placement.chosen
    );
    // Only confirmed numbers: the chosen layout's share is its Monte Carlo share.
    let chosen: Vec<Observer> = run
        .placement
        .chosen
        .iter()
        .map(|n| c.iter().find(|o| &o.name == n).unwrap().clone())
        .collect();
    let again = monte_carlo_score(&layout(&s, &chosen), samples, 5, None, "").unwrap();
    assert_eq!(again.share(), got);
}
