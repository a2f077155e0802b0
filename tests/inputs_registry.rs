//! The process-wide registry of input files (`gbuf::base::files::protect_input`): a library user can see it and clear it.
//! Its own test binary, so clearing cannot race with other tests' protected inputs.

use gbuf::base::files::{check_not_input, clear_protected_inputs, protect_input, protected_inputs};

#[test]
fn inputs_are_listed_refused_as_outputs_and_cleared() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("in.exr");
    std::fs::write(&f, b"x").unwrap();
    protect_input(&f);
    let canonical = std::fs::canonicalize(&f).unwrap();
    assert_eq!(protected_inputs(), vec![canonical]);
    assert!(check_not_input(&f).is_err(), "a read file is refused as an output");
    clear_protected_inputs();
    assert!(protected_inputs().is_empty());
    assert!(check_not_input(&f).is_ok(), "after a clear it may be written");
}
