//! The compiled kernels: every SIMD intrinsic the project's code uses is inlined into the function
//! that calls it. An intrinsic compiled as a call (in a function without the CPU features it needs,
//! such as an array map outside the AVX2 function that `pulp` makes) costs ten times its instruction.

use std::process::Command;

/// Functions of dependencies the project does not write, allowed to call intrinsics (the runtime's
/// own CPU feature detection among them: `std_detect`, and `compiler_builtins`' for its maths).
const NOT_OURS: [&str; 3] = ["font_kit::", "std_detect::", "compiler_builtins::"];

#[test]
fn no_intrinsic_is_left_as_a_call() {
    if cfg!(debug_assertions) {
        eprintln!("skipped: intrinsics are calls in unoptimised builds; the release build is checked");
        return;
    }
    let binary = env!("CARGO_BIN_EXE_raylume");
    let Ok(out) = Command::new("objdump").args(["-d", "-C", "--no-show-raw-insn", binary]).output() else {
        eprintln!("skipped: objdump (binutils) is not installed");
        return;
    };
    assert!(out.status.success(), "objdump: {}", String::from_utf8_lossy(&out.stderr));
    let listing = String::from_utf8_lossy(&out.stdout);
    let mut function = "";
    let mut offenders = Vec::new();
    let mut functions = 0;
    for line in listing.lines() {
        if line.ends_with(">:") {
            function = line;
            functions += 1;
        } else if line.contains("call")
            && line.contains("core_arch::x86")
            && !NOT_OURS.iter().any(|n| function.contains(n))
        {
            offenders.push(format!("{function} {}", line.trim()));
        }
    }
    assert!(functions > 1000, "objdump listed {functions} functions of {binary}");
    assert!(offenders.is_empty(), "intrinsics compiled as calls:\n{}", offenders.join("\n"));
}
