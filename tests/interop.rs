//! `results.parquet` opens in pyarrow and DuckDB with the expected schema, units and study
//! metadata. Needs python3 with pyarrow and duckdb: built with MC_STUDY_INTEROP=1 (`.ci/run`
//! installs them and sets it) the test runs and their absence is a failure; without the
//! variable it is reported as ignored.

mod common;

use common::{scratch, study_path};
use mc_study::study::merge::merge;
use mc_study::study::runner::{run, RunOptions};
use mc_study::study::Study;
use std::process::Command;

const CHECK: &str = r#"
import sys, json
import pyarrow.parquet as pq
import duckdb
path = sys.argv[1]
t = pq.read_table(path)
s = t.schema
names = [f.name for f in s]
assert names == ["sample_id", "contacts.floor.e", "bodies.ball.position.z", "first_impact_time",
                 "apex_after_first_bounce", "steps", "max_penetration", "max_solver_residual",
                 "nonconverged_steps", "wall_ms", "status", "error"], names
assert str(s.field("sample_id").type) == "uint64"
assert str(s.field("first_impact_time").type) == "double"
assert str(s.field("status").type) == "string"
unit = lambda n: s.field(n).metadata[b"unit"].decode()
assert unit("bodies.ball.position.z") == "m", unit("bodies.ball.position.z")
assert unit("contacts.floor.e") == "1"
assert unit("first_impact_time") == "s"
assert unit("max_penetration") == "m"
meta = {k.decode(): v.decode() for k, v in s.metadata.items()}
assert len(meta["mc_study.study_hash"]) == 64
assert "contacts.floor.e" in meta["mc_study.study_yaml"]
assert meta["mc_study.version"].startswith("mc-study ")
assert t.num_rows == 20
assert t.column("sample_id").to_pylist() == list(range(20))
n, ok, lo, hi = duckdb.sql(
    f"select count(*), count(*) filter (where status = 'ok'), min(first_impact_time), max(first_impact_time) from '{path}'"
).fetchall()[0]
assert (n, ok) == (20, 20), (n, ok)
assert 0.3 < lo <= hi < 0.6, (lo, hi)
print(json.dumps({"rows": t.num_rows, "duckdb_count": n}))
"#;

#[test]
#[cfg_attr(
    not(interop),
    ignore = "needs python3 with pyarrow and duckdb: `pip install pyarrow duckdb`, then MC_STUDY_INTEROP=1 cargo test (.ci/run does both)"
)]
fn results_open_in_pyarrow_and_duckdb_with_units_and_study_metadata() {
    let available = Command::new("python3")
        .args(["-c", "import pyarrow, duckdb"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        available,
        "MC_STUDY_INTEROP=1 but python3 cannot import pyarrow and duckdb"
    );
    let study = Study::load(&study_path("bouncing-ball", "study.yaml"), Some(20)).unwrap();
    let out = scratch("interop");
    let mut o = RunOptions::new(out.clone());
    o.progress = false;
    run(&study, &o).unwrap();
    let m = merge(&out, false).unwrap();
    let script = out.join("check.py");
    std::fs::write(&script, CHECK).unwrap();
    let result = Command::new("python3")
        .arg(&script)
        .arg(&m.path)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&result.stdout);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        result.status.success(),
        "python check failed:\n{stdout}\n{stderr}"
    );
    assert!(stdout.contains("\"duckdb_count\": 20"), "{stdout}");
}
