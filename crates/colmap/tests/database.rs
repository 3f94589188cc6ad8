//! The database reader against pycolmap's reading of the same file, and its read-only promise.

use std::path::Path;

use approx::assert_abs_diff_eq;
use crashrig_colmap::SensorType;
use crashrig_colmap::database::{Database, image_ids_from_pair_id, pair_id};
use nalgebra::Matrix3;

use crate::common::{f, fixture, fv, json, u};

fn db_path() -> std::path::PathBuf {
    fixture("rig_opencv/database.db")
}

/// A writable copy of the fixture database (tests that edit rows).
fn db_copy() -> (tempfile::TempDir, std::path::PathBuf) {
    let tmp = tempfile::tempdir().expect("tmp");
    let p = tmp.path().join("database.db");
    std::fs::copy(db_path(), &p).expect("copy");
    (tmp, p)
}

fn mat(v: &serde_json::Value) -> Option<Matrix3<f64>> {
    if v.is_null() {
        return None;
    }
    let rows: Vec<f64> = v.as_array().expect("rows").iter().flat_map(fv).collect();
    Some(Matrix3::from_row_slice(&rows))
}

#[test]
fn database_nominal() {
    let g = json(&fixture("rig_opencv/database_golden.json"));
    let db = Database::open(&db_path()).expect("opens");
    let c = db.counts().expect("counts");
    assert_eq!(c.user_version as u64, u(&g["user_version"]));
    assert_eq!(c.cameras, u(&g["num_cameras"]));
    assert_eq!(c.images, u(&g["num_images"]));
    assert_eq!(c.rigs, u(&g["num_rigs"]));
    assert_eq!(c.frames, u(&g["num_frames"]));
    assert_eq!(c.matched_pairs, u(&g["num_matched_image_pairs"]));
    assert_eq!(c.verified_pairs, u(&g["num_verified_image_pairs"]));
    assert_eq!(c.keypoints, c.images, "every image has a keypoints row");

    let cams = db.cameras().expect("cameras");
    for (c, j) in cams.iter().zip(g["cameras"].as_array().expect("cameras")) {
        assert_eq!(u64::from(c.record.camera_id), u(&j["id"]));
        assert_eq!(
            c.record.camera.model.name(),
            j["model"].as_str().expect("model")
        );
        assert_eq!(c.record.camera.params, fv(&j["params"]));
        assert_eq!(
            c.prior_focal_length,
            j["prior_focal_length"].as_bool().expect("bool")
        );
    }
    let images = db.images().expect("images");
    for (i, j) in images.iter().zip(g["images"].as_array().expect("images")) {
        assert_eq!(u64::from(i.image_id), u(&j["id"]));
        assert_eq!(i.name, j["name"].as_str().expect("name"));
        assert_eq!(u64::from(i.camera_id), u(&j["camera_id"]));
        assert_eq!(
            db.image_id_by_name(&i.name).expect("query"),
            Some(i.image_id)
        );
    }
    assert_eq!(db.image_id_by_name("no such image").expect("query"), None);

    let rigs = db.rigs().expect("rigs");
    let gr = g["rigs"].as_array().expect("rigs");
    assert_eq!(rigs.len(), gr.len());
    for (r, j) in rigs.iter().zip(gr) {
        assert_eq!(u64::from(r.rig_id), u(&j["id"]));
        assert_eq!(
            r.ref_sensor.map(|s| u64::from(s.id)),
            Some(u(&j["ref_sensor"][1]))
        );
        let js = j["sensors"].as_array().expect("sensors");
        assert_eq!(r.sensors.len(), js.len());
        for (s, k) in r.sensors.iter().zip(js) {
            assert_eq!(u64::from(s.sensor.id), u(&k["id"]));
            let p = s.sensor_from_rig.expect("pose stored");
            // Stored doubles are read unchanged; pycolmap's are the same (unit) quaternion.
            let theirs = fv(&k["pose"]);
            assert_abs_diff_eq!(&p.to_array()[..], &theirs[..], epsilon = 1e-15);
        }
    }
    let frames = db.frames().expect("frames");
    for (fr, j) in frames.iter().zip(g["frames"].as_array().expect("frames")) {
        assert_eq!(u64::from(fr.frame_id), u(&j["id"]));
        let ours: Vec<[u64; 3]> = fr
            .data_ids
            .iter()
            .map(|d| [d.sensor.sensor_type.code() as u64, d.sensor.id.into(), d.id])
            .collect();
        let theirs: Vec<[u64; 3]> = j["data_ids"]
            .as_array()
            .expect("ids")
            .iter()
            .map(|d| [u(&d[0]), u(&d[1]), u(&d[2])])
            .collect();
        assert_eq!(ours, theirs);
        assert!(
            fr.data_ids
                .iter()
                .all(|d| d.sensor.sensor_type == SensorType::Camera)
        );
    }

    let kh = &g["keypoints_head"];
    for i in &images {
        let kp = db.keypoints(i.image_id).expect("keypoints");
        assert_eq!(kp.len() as u64, u(&kh[format!("{}_rows", i.image_id)]));
        for (k, j) in kp
            .iter()
            .zip(kh[i.image_id.to_string()].as_array().expect("rows"))
        {
            let row = fv(j);
            // f32 values widened to f64 by pycolmap: exact.
            let ours = [
                k.xy[0],
                k.xy[1],
                k.affine[0],
                k.affine[1],
                k.affine[2],
                k.affine[3],
            ]
            .map(f64::from);
            assert_eq!(ours.to_vec(), row);
        }
    }
    let d = db.descriptors(1).expect("query").expect("row");
    let gd = &g["descriptors_1"];
    assert_eq!(
        (d.rows as u64, d.cols as u64),
        (u(&gd["rows"]), u(&gd["cols"]))
    );
    assert_eq!(d.extractor_type as u64, u(&gd["type"]));
    let head: Vec<u64> = gd["head"].as_array().expect("head").iter().map(u).collect();
    assert_eq!(
        d.data[..16]
            .iter()
            .map(|&b| u64::from(b))
            .collect::<Vec<_>>(),
        head
    );
}

#[test]
fn database_pairs_oriented_as_asked() {
    let g = json(&fixture("rig_opencv/database_golden.json"));
    let db = Database::open(&db_path()).expect("opens");
    for j in g["pairs"].as_array().expect("pairs") {
        let (a, b) = (u(&j["a"]) as u32, u(&j["b"]) as u32);
        let m = db.matches(a, b).expect("matches");
        let gm: Vec<[u32; 2]> = j["matches"]
            .as_array()
            .expect("m")
            .iter()
            .map(|r| [u(&r[0]) as u32, u(&r[1]) as u32])
            .collect();
        assert_eq!(m, gm, "matches {a} {b}");
        let t = db.two_view_geometry(a, b).expect("query").expect("row");
        assert_eq!(t.config as u64, u(&j["config"]));
        let gi: Vec<[u32; 2]> = j["inliers"]
            .as_array()
            .expect("i")
            .iter()
            .map(|r| [u(&r[0]) as u32, u(&r[1]) as u32])
            .collect();
        assert_eq!(t.inliers, gi, "inliers {a} {b}");
        // F and E are copied or transposed (exact); H is inverted when swapped (LU vs. Eigen:
        // agreement to 1e-12 relative).
        for (ours, key) in [(t.f, "F"), (t.e, "E")] {
            match (ours, mat(&j[key])) {
                (Some(x), Some(y)) => assert_abs_diff_eq!(x, y, epsilon = 0.0),
                (None, None) => {}
                other => panic!("{key} {a} {b}: {other:?}"),
            }
        }
        match (t.h, mat(&j["H"])) {
            (Some(x), Some(y)) => approx::assert_relative_eq!(x, y, max_relative = 1e-12),
            (None, None) => {}
            other => panic!("H {a} {b}: {other:?}"),
        }
        let gp = &j["cam2_from_cam1"];
        match t.b_from_a {
            Some(p) => {
                let v = fv(gp);
                let theirs = crashrig_colmap::RawPose::from_array([
                    v[0], v[1], v[2], v[3], v[4], v[5], v[6],
                ])
                .to_rigid()
                .expect("valid");
                // One inversion in double precision on unit-scale values.
                assert_abs_diff_eq!(
                    p.rotation.to_rotation_matrix().matrix(),
                    theirs.rotation.to_rotation_matrix().matrix(),
                    epsilon = 1e-14
                );
                assert_abs_diff_eq!(
                    p.translation.vector,
                    theirs.translation.vector,
                    epsilon = 1e-14
                );
            }
            None => assert!(gp.is_null()),
        }
        // Asking the other way round swaps back.
        let back = db.two_view_geometry(b, a).expect("query").expect("row");
        let swapped: Vec<[u32; 2]> = t.inliers.iter().map(|&[x, y]| [y, x]).collect();
        assert_eq!(back.inliers, swapped);
    }
    assert!(db.two_view_geometry(1, 1000).expect("query").is_none());
    assert!(db.matches(1, 1000).expect("query").is_empty());
}

#[test]
fn database_pose_priors() {
    let g = json(&fixture("rig_opencv/database_golden.json"));
    let db = Database::open(&db_path()).expect("opens");
    let priors = db.pose_priors().expect("priors");
    let gp = g["pose_priors"].as_array().expect("priors");
    assert_eq!(priors.len(), gp.len());
    for (p, j) in priors.iter().zip(gp) {
        assert_eq!(p.pose_prior_id as u64, u(&j["id"]));
        assert_eq!(p.data_id.id, u(&j["data_id"][2]));
        assert_eq!(u64::from(p.data_id.sensor.id), u(&j["data_id"][1]));
        let pos = p.position.expect("position set");
        assert_eq!(pos.to_vec(), fv(&j["position"]));
        assert_eq!(p.coordinate_system as u64, u(&j["coordinate_system"]));
        assert!(
            p.position_covariance.is_none(),
            "all-NaN covariance is unset"
        );
        assert!(p.gravity.is_some());
    }
    let _ = f;
}

fn modified(path: &Path) -> std::time::SystemTime {
    std::fs::metadata(path)
        .expect("meta")
        .modified()
        .expect("mtime")
}

#[test]
fn database_open_is_read_only() {
    let (tmp, p) = db_copy();
    let before = std::fs::read(&p).expect("bytes");
    let t0 = modified(&p);
    {
        let db = Database::open(&p).expect("opens");
        db.counts().expect("counts");
        db.cameras().expect("cameras");
        db.rigs().expect("rigs");
        db.frames().expect("frames");
        db.keypoints(1).expect("kp");
        db.two_view_geometry(2, 1).expect("tvg");
        db.pose_priors().expect("priors");
    }
    assert_eq!(std::fs::read(&p).expect("bytes"), before, "bytes unchanged");
    assert_eq!(modified(&p), t0, "mtime unchanged");
    let names: Vec<String> = std::fs::read_dir(tmp.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        vec!["database.db".to_owned()],
        "no -wal/-shm/-journal left behind"
    );
}

#[test]
fn database_keypoint_columns() {
    let (_tmp, p) = db_copy();
    {
        let conn = rusqlite::Connection::open(&p).expect("writable copy");
        let two: Vec<u8> = [10.5f32, 20.25, 30.0, 40.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        conn.execute(
            "UPDATE keypoints SET rows = 2, cols = 2, data = ?1 WHERE image_id = 1",
            [two],
        )
        .expect("update");
        let four: Vec<u8> = [1.0f32, 2.0, 2.0, std::f32::consts::FRAC_PI_2]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        conn.execute(
            "UPDATE keypoints SET rows = 1, cols = 4, data = ?1 WHERE image_id = 2",
            [four],
        )
        .expect("update");
        conn.execute(
            "UPDATE keypoints SET rows = 0, cols = 6, data = NULL WHERE image_id = 3",
            [],
        )
        .expect("update");
        conn.execute(
            "UPDATE keypoints SET rows = 1, cols = 3, data = zeroblob(12) WHERE image_id = 4",
            [],
        )
        .expect("update");
        conn.pragma_update(None, "journal_mode", "DELETE")
            .expect("no wal");
    }
    let db = Database::open(&p).expect("opens");
    let k = db.keypoints(1).expect("2 columns");
    assert_eq!(k.len(), 2);
    assert_eq!((k[1].xy, k[1].affine), ([30.0, 40.0], [1.0, 0.0, 0.0, 1.0]));
    let k = db.keypoints(2).expect("4 columns");
    // Scale 2 at 90°: a = [s cos o, −s sin o, s sin o, s cos o] (f32 rounding of cos(π/2)).
    assert_abs_diff_eq!(
        &k[0].affine[..],
        &[0.0f32, -2.0, 2.0, 0.0][..],
        epsilon = 1e-6
    );
    assert!(db.keypoints(3).expect("rows = 0").is_empty());
    match db.keypoints(4) {
        Err(crashrig_colmap::Error::BadRow { table, row, .. }) => {
            assert_eq!((table, row), ("keypoints", 4))
        }
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn database_legacy_sentinels() {
    let (_tmp, p) = db_copy();
    {
        let conn = rusqlite::Connection::open(&p).expect("writable copy");
        let identity: Vec<u8> = [1.0f64, 0.0, 0.0, 0.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let zero3 = vec![0u8; 24];
        let zero9 = vec![0u8; 72];
        conn.execute(
            "UPDATE two_view_geometries SET qvec = ?1, tvec = ?2, F = ?3 WHERE pair_id = ?4",
            rusqlite::params![identity, zero3, zero9, pair_id(1, 2) as i64],
        )
        .expect("update");
        conn.pragma_update(None, "journal_mode", "DELETE")
            .expect("no wal");
        conn.pragma_update(None, "user_version", 3900)
            .expect("old version");
    }
    let db = Database::open(&p).expect("opens");
    assert_eq!(db.user_version(), 3900);
    let t = db.two_view_geometry(1, 2).expect("query").expect("row");
    assert!(
        t.b_from_a.is_none(),
        "identity pose is the 3.x 'unset' sentinel"
    );
    assert!(t.f.is_none(), "all-zero F is the 3.x 'unset' sentinel");
    assert!(t.e.is_some());
    // One NULL of qvec/tvec is an error.
    drop(db);
    {
        let conn = rusqlite::Connection::open(&p).expect("writable copy");
        conn.execute(
            "UPDATE two_view_geometries SET qvec = NULL WHERE pair_id = ?1",
            [pair_id(1, 3) as i64],
        )
        .expect("update");
        conn.pragma_update(None, "journal_mode", "DELETE")
            .expect("no wal");
    }
    let db = Database::open(&p).expect("opens");
    assert!(matches!(
        db.two_view_geometry(3, 1),
        Err(crashrig_colmap::Error::BadRow { .. })
    ));
}

#[test]
fn database_pair_id_rule() {
    assert_eq!(pair_id(1, 2), 2_147_483_649);
    assert_eq!(pair_id(2, 1), 2_147_483_649);
    assert_eq!(image_ids_from_pair_id(pair_id(7, 3)), (3, 7));
    let big = 2_147_483_646u32;
    assert_eq!(
        image_ids_from_pair_id(pair_id(big, big - 1)),
        (u64::from(big - 1), u64::from(big))
    );
}

#[test]
fn database_rejects_non_database() {
    let err = Database::open(&fixture("rig_opencv/bin/cameras.bin")).and_then(|d| d.counts());
    match err {
        Err(e) => assert_eq!(e.path(), fixture("rig_opencv/bin/cameras.bin")),
        Ok(c) => panic!("read a binary model file as a database: {c:?}"),
    }
    assert!(matches!(
        Database::open(Path::new("/nonexistent/database.db")),
        Err(crashrig_colmap::Error::Io { .. })
    ));
}

#[test]
fn database_sees_wal_of_an_open_writer() {
    // COLMAP keeps the database open in WAL mode: committed rows sit in `database.db-wal`.
    let (tmp, p) = db_copy();
    let writer = rusqlite::Connection::open(&p).expect("writable copy");
    let mode: String = writer
        .pragma_query_value(None, "journal_mode", |r| r.get(0))
        .expect("mode");
    assert_eq!(mode, "wal");
    writer
        .execute(
            "INSERT INTO cameras (camera_id, model, width, height, params, prior_focal_length) VALUES (99, 0, 10, 10, ?1, 0)",
            [[5.0f64, 5.0, 5.0].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()],
        )
        .expect("insert");
    assert!(tmp.path().join("database.db-wal").exists());
    let main_before = std::fs::read(&p).expect("bytes");
    {
        let db = Database::open(&p).expect("opens next to a live writer");
        assert_eq!(
            db.counts().expect("counts").cameras,
            5,
            "the WAL row is visible"
        );
        assert_eq!(
            db.cameras()
                .expect("cameras")
                .last()
                .map(|c| c.record.camera_id),
            Some(99)
        );
    }
    assert_eq!(
        std::fs::read(&p).expect("bytes"),
        main_before,
        "main file untouched"
    );
    drop(writer);
}

#[test]
fn database_other_sqlite_file_is_not_a_colmap_database() {
    // An SQLite file with an unrelated table must not read as an empty COLMAP database
    // (contract review: `colmap info` exited 0 with all counts 0 on such a file).
    let tmp = tempfile::tempdir().expect("tmp");
    let p = tmp.path().join("other.db");
    {
        let c = rusqlite::Connection::open(&p).expect("create");
        c.execute("CREATE TABLE notes (id INTEGER PRIMARY KEY, text TEXT)", [])
            .expect("table");
    }
    let err = Database::open(&p).expect_err("not a COLMAP database");
    assert!(
        matches!(
            err,
            crashrig_colmap::Error::NotADatabase {
                table: "cameras",
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("other.db"), "{err}");
}

/// Files of `dir` with their bytes and modification times.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>, std::time::SystemTime)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .expect("list")
        .map(|e| {
            let e = e.expect("entry");
            let m = e.metadata().expect("meta");
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).expect("bytes"),
                m.modified().expect("mtime"),
            )
        })
        .collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v
}

#[test]
fn database_wal_without_shm_creates_nothing_and_reads_the_wal() {
    // A crashed COLMAP leaves `database.db` + `database.db-wal` (rows only in the WAL) and no
    // `-shm`. Build that state: write through a WAL connection with checkpoints off, then copy
    // the two files (not the -shm) to a fresh directory while the writer is still open.
    let (tmp, p) = db_copy();
    let writer = rusqlite::Connection::open(&p).expect("writable copy");
    writer
        .pragma_update(None, "wal_autocheckpoint", 0)
        .expect("no checkpoints");
    writer
        .execute(
            "INSERT INTO cameras (camera_id, model, width, height, params, prior_focal_length) VALUES (77, 0, 10, 10, ?1, 0)",
            [[5.0f64, 5.0, 5.0].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()],
        )
        .expect("insert");
    let crashed = tmp.path().join("crashed");
    std::fs::create_dir(&crashed).expect("dir");
    let db = crashed.join("database.db");
    std::fs::copy(&p, &db).expect("copy db");
    std::fs::copy(
        tmp.path().join("database.db-wal"),
        crashed.join("database.db-wal"),
    )
    .expect("copy wal");
    drop(writer);
    let before = snapshot(&crashed);
    assert_eq!(before.len(), 2, "database.db and database.db-wal only");
    {
        let d = Database::open(&db).expect("opens");
        assert_eq!(
            d.cameras()
                .expect("cameras")
                .last()
                .map(|c| c.record.camera_id),
            Some(77),
            "the row that exists only in the WAL is read"
        );
    }
    assert_eq!(
        snapshot(&crashed),
        before,
        "no -shm created, database and WAL unchanged (bytes and mtime)"
    );

    // An existing -shm is not rewritten either.
    std::fs::write(crashed.join("database.db-shm"), vec![0u8; 32768]).expect("shm");
    let before = snapshot(&crashed);
    {
        let d = Database::open(&db).expect("opens with a stale -shm");
        assert_eq!(d.counts().expect("counts").cameras, 5);
    }
    assert_eq!(
        snapshot(&crashed),
        before,
        "-shm, -wal and database untouched"
    );
}
