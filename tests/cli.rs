//! End-to-end tests of the `sweep` binary.

use assert_cmd::Command;

#[test]
fn schema_is_json() {
    let out = Command::cargo_bin("sweep").unwrap().arg("schema").output().unwrap();
    assert!(out.status.success());
}
