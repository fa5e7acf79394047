"""What a run computes never calls code whose last bits depend on the CPU (the reproducibility contract, README
"Reproducible results"), checked on the source with `ast`, so that a new call shows here before any fixture breaks.

CPU-dependent: the C library's transcendental functions (glibc picks FMA or SSE2 variants of sin, cos, exp, log, pow,
atan2, ... per CPU, and Python's `math` and `**` on floats call them), numpy's transcendental ufuncs (its own SIMD
kernels per CPU) and BLAS/LAPACK (`@`, `dot`, `linalg`: OpenBLAS picks its kernel per CPU). Portable: IEEE +, -, *,
/, sqrt on floats and on numpy arrays elementwise, and the functions of `numerics`.

The modules checked are those a step, a channel decision or a run's set-up goes through; the functions allowed are
named with the reason (plotting, a test reference, a figure of their own).
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CHECKED = (
    "vehicles", "comms", "numerics", "supervisor/plan",
    "supervisor/config/fleet.py", "supervisor/config/vehicle_models.py",
    # What a run's summary, a sweep's row and the report's numbers are computed with.
    "supervisor/analysis/series.py", "supervisor/analysis/summary.py", "supervisor/analysis/metrics.py",
    "supervisor/analysis/rundata.py", "supervisor/tools/sweep.py",
)  # fmt: skip

MATH_FORBIDDEN = {
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh", "acosh", "atanh", "exp",
    "exp2", "expm1", "log", "log2", "log10", "log1p", "pow", "erf", "erfc", "gamma", "lgamma", "cbrt",
}  # fmt: skip
NUMPY_FORBIDDEN = MATH_FORBIDDEN | {
    "arcsin", "arccos", "arctan", "arctan2", "power", "float_power", "linalg", "dot", "vdot", "matmul", "einsum",
    "inner", "tensordot", "hypot",
}  # fmt: skip

# (module, function) -> why it may use CPU-dependent kernels: nothing a run records goes through it.
ALLOWED = {
    ("vehicles/paths.py", "Helix.positions"): "p_d at many gammas for plotting (the search uses evaluate_floats)",
    ("vehicles/paths.py", "Lawnmower.positions"): "p_d at many gammas for plotting",
    ("vehicles/geometry.py", "orthonormalize"): "LAPACK's SVD: the tests' reference, and the guard of a reflection",
    ("vehicles/coordination.py", "correction_vector"): "law (5) in vector form, to check the decentralised one",
    ("vehicles/coordination.py", "l_k"): "the projection L_K, for analysis and tests",
    (
        "comms/records/graph.py",
        "algebraic_connectivity",
    ): "lambda_2 by LAPACK: the one recorded value held to a tolerance",
    (
        "comms/channel/link_budget.py",
        "LinkBudgetRange.success_at",
    ): "vectorised success over fades: `cpf per` figures only",
    (
        "comms/channel/fading.py",
        "_fading_cdf_db",
    ): "the fade distribution for the mean over fades: `cpf per` figures only",
    (
        "comms/channel/fading.py",
        "gain_distribution",
    ): "the fade distribution for the mean over fades: `cpf per` figures only",
    ("comms/channel/fading.py", "mean_over_gain"): "the mean over fades: `cpf per` figures only",
}


def _modules() -> list[Path]:
    found: list[Path] = []
    for name in CHECKED:
        path = ROOT / name
        found.extend(sorted(path.rglob("*.py")) if path.is_dir() else [path])
    return found


def _violations(tree: ast.Module) -> list[tuple[str, int, str]]:
    """(enclosing function, line, what) of every CPU-dependent call or operator in a module."""
    out: list[tuple[str, int, str]] = []

    def visit(node: ast.AST, scope: str) -> None:
        for child in ast.iter_child_nodes(node):
            inner = scope
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                inner = f"{scope}.{child.name}" if scope else child.name
            if isinstance(child, ast.Attribute) and child.attr.endswith("Error"):
                continue  # an exception class (np.linalg.LinAlgError) computes nothing
            what = _what(child)
            if what:
                out.append((scope, child.lineno, what))  # type: ignore[attr-defined]
            visit(child, inner)

    visit(tree, "")
    return out


def _what(node: ast.AST) -> str | None:
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.MatMult):
        return "@ (BLAS)"
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow) and not _integer(node.left):
        return "** (the C library's pow)"
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
        if node.value.id == "math" and node.attr in MATH_FORBIDDEN:
            return f"math.{node.attr}"
        if node.value.id in ("np", "numpy", "special", "scipy") and node.attr in NUMPY_FORBIDDEN:
            return f"{node.value.id}.{node.attr}"
    return None


def _integer(node: ast.expr) -> bool:
    """An int literal: int ** int is exact integer arithmetic in Python."""
    return isinstance(node, ast.Constant) and type(node.value) is int


def _scope_allowed(path: str, scope: str) -> bool:
    return any(path == p and (scope == f or scope.startswith(f + ".")) for p, f in ALLOWED)


def test_the_checked_modules_exist() -> None:
    assert len(_modules()) > 40


def test_no_cpu_dependent_arithmetic_where_a_run_computes() -> None:
    found = []
    for path in _modules():
        name = path.relative_to(ROOT).as_posix()
        for scope, line, what in _violations(ast.parse(path.read_text(encoding="utf-8"))):
            if not _scope_allowed(name, scope):
                found.append(f"{name}:{line} {scope or '<module>'}: {what}")
    assert found == []


def test_the_check_sees_each_kind_of_call() -> None:
    """The checker itself: each CPU-dependent form is found, the portable ones are not."""
    bad = "import math\nimport numpy as np\ndef f(a, b, x):\n"
    bad += "    return a @ b, x ** 2, math.sin(x), np.exp(a), np.linalg.inv(a)\n"
    expected = ["@ (BLAS)", "** (the C library's pow)", "math.sin", "np.exp", "np.linalg"]
    assert [w for _, _, w in _violations(ast.parse(bad))] == expected
    good = "import math, numpy as np\nfrom numerics import sin\ndef f(a, x):\n"
    good += "    return a * a, math.sqrt(x), sin(x), {**a}, 2**63\n"
    good += "try:\n    pass\nexcept np.linalg.LinAlgError:\n    pass\n"
    assert _violations(ast.parse(good)) == []


def test_every_allowed_entry_exists() -> None:
    """An allowance whose function moved or went must go too, or it would silently allow a new one."""
    for path, function in ALLOWED:
        tree = ast.parse((ROOT / path).read_text(encoding="utf-8"))
        names = {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.ClassDef)}
        assert set(function.split(".")) <= names, (path, function)
