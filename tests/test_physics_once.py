"""The physics of fitlab.physics exists once: an AST walk over fitlab/ finds no second definition.

Two checks, over every module of fitlab/ but fitlab/physics/ (and the generated code, which imports nothing):

* **Expressions.** :data:`PATTERNS` holds the characteristic expressions of each formula, in the arrangements the
  project's copies had and in fitlab.physics's own: a pattern is Python text whose names are wildcards (one name
  matches one subexpression, the same name the same subexpression) and whose calls match whatever namespace they
  are made through (``np.sqrt``, ``jnp.sqrt``, ``sp.sqrt``, ``math.sqrt`` and ``xp.sqrt`` are all ``sqrt``;
  ``acos`` is ``arccos``); numbers match by value (``4.0 / 3.0`` is ``4 / 3``), ``x ** 2`` also matches ``x * x``.
  A subexpression of a module that matches a pattern is a copy.
* **Names.** A function defined outside fitlab.physics under the name of a physics function (:data:`NAMES`) must
  call into fitlab.physics (a checked wrapper that delegates, such as an exact engine's public function); names of
  helpers that the copies had and fitlab.physics replaces (:data:`GONE`) may not be defined at all.

``python tests/test_physics_once.py DIR`` prints what the checks find in another fitlab/ folder (a checkout from
before fitlab.physics finds the copies it replaced).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: quantity -> the characteristic expressions of its formula
PATTERNS = {
    "Schlick's Fresnel": [
        "(1 - c) ** 5",
        "f0 + (1 - f0) * (m2 * m2 * m)",
        "f0 + (1 - f0) * schlick_weight(c)",
        "(20 * f + 1) / 21",
    ],
    "conductor Fresnel": [
        "sqrt(t * t + 4 * e * e * k * k)",  # a^2 + b^2 of the real form
        "sqrt(t ** 2 + 4 * e ** 2 * k)",
        "sqrt(0.5 * (z + t))",  # a of the real form
        "sqrt((z + t) / 2)",
        "hypot(t, 2 * ek)",
        "(z - 2 * a * c + c ** 2) / (z + 2 * a * c + c ** 2)",
        "(e2 * mu - w) / (e2 * mu + w)",  # the complex amplitude r_p
        "((c - a) ** 2 + b) / ((c + a) ** 2 + b)",
    ],
    "dielectric Fresnel": ["((e - 1) * (e + 1) + c * c) / (e * e)", "(c - e * t) / (c + e * t)"],
    "Gulbrandsen's map": [
        "g * (1 - r) / (1 + r) + (1 - g) * (1 + s) / (1 - s)",
        "(r * (n + 1) ** 2 - (n - 1) ** 2) / (1 - r)",
    ],
    "F82-tint": ["s * (1 - t) / (b * (1 - b) ** 6)", "s * (1 - t) / (b * (m * m * m))"],
    "GGX D": [
        "a2 / (pi * (a2 * m + (1 - m)) ** 2)",
        "a2 * (x + z) ** 2 / (pi * (a2 * z + x) ** 2)",
        "b / (pi * (z ** 2 * (b - 1) + 1) ** 2)",
        "1 / (pi * ax * ay * m * m * (1 + e) ** 2)",
    ],
    "Beckmann D": ["exp(-e) / (pi * ax * ay * m * m)", "exp(-x / (a * z)) * (x + z) ** 2 / (pi * a * z * z)"],
    "Smith Lambda": [
        "t / (2 * (1 + sqrt(1 + t)))",
        "(sqrt(1 + t) - 1) / 2",
        "(-1 + sqrt(1 + t)) / 2",
        "sqrt(a2 + (1 - a2) * mu * mu)",
        "exp(-a * a) / (a * s) - erfc(a)",
    ],
    "Smith G1 and G2": ["2 * mu / (mu + s)", "2 * i * o / (o * si + i * so)", "1 / (1 + li + lo)"],
    "Walter's Beckmann G1": ["(3.535 * b + 2.181) / (b ** 2 + 2.276 * b + 2.577)"],
    "Oren-Nayar": ["1 - s / (2 * (s + a))", "0.45 * s / (s + 0.09)", "sqrt(1 - lo * lo) * sqrt(1 - hi * hi) / hi"],
    "the Lambert sphere's phase function": [
        "sqrt((1 - u) * (1 + u)) - u * arccos(u)",
        "sqrt(Max(0, 1 - u ** 2)) - u * arccos(u)",
        "sin(t) + cos(t) * (pi - t)",
        "2 * sqrt(v * (1 - v)) - (1 - 2 * v) * x",
        "1 - 4 / 3 * u + 5 / 32 * (3 * u * u - 1)",
        "1 - 4 / 3 * u + 5 / 16 * 0.5 * (3 * u * u - 1)",
        "27 / 32 - 4 / 3 * u + 15 / 32 * u * u",
    ],
}

#: physics functions: defined elsewhere only as wrappers that call fitlab.physics
NAMES = {
    "schlick_weight", "fresnel_schlick", "schlick_generalised", "lazanyi", "f82_tint", "fresnel_conductor",
    "fresnel_dielectric", "fresnel_dielectric_transmittance", "normal_reflectance", "gulbrandsen_index",
    "gulbrandsen_parameters", "fresnel_reflectance", "ggx_ndf", "beckmann_ndf", "ndf", "smith_lambda", "ggx_lambda",
    "beckmann_lambda", "smith_g1", "smith_g2", "ggx_g1", "ggx_g2", "oren_nayar_brdf", "oren_nayar_coefficients",
    "phase_function", "three_term_phase_function", "p_true", "p_three_term", "beckmann_g1",
}  # fmt: skip
#: the copies' own helpers, replaced by fitlab.physics
GONE = {
    "root_term",
    "ndf_from_tangents",
    "mu_i_visibility",
    "brdf_kernel",
    "conductor_reflectance",
    "schlick_term",
    "lambda_",
    "_lambda_up",
    "_stretched_tan2",
    "_p_true",
    "_p_three_term",
    "transmission_g2",
    "_conductor_kink",
}

#: a call's function by its last name, with numpy's and sympy's names made one
_ALIASES = {"acos": "arccos", "asin": "arcsin", "Abs": "abs", "fabs": "abs"}


def _callee(node: ast.expr) -> str | None:
    if isinstance(node, ast.Attribute):
        return _ALIASES.get(node.attr, node.attr)
    if isinstance(node, ast.Name):
        return _ALIASES.get(node.id, node.id)
    return None


def _number(node: ast.expr) -> float | None:
    """The value of a numeric literal or of an arithmetic of literals (4.0 / 3.0, -1, 2 ** -5)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return float(node.value)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        v = _number(node.operand)
        return None if v is None else -v
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Div, ast.Mult, ast.Pow)):
        a, b = _number(node.left), _number(node.right)
        if a is None or b is None:
            return None
        try:
            return a / b if isinstance(node.op, ast.Div) else a * b if isinstance(node.op, ast.Mult) else a**b
        except (ZeroDivisionError, OverflowError):
            return None
    return None


def _matches(pattern: ast.expr, node: ast.expr, bound: dict) -> bool:
    """Does ``node`` match ``pattern`` (module docstring), binding the pattern's names in ``bound``?"""
    value = _number(pattern)
    if value is not None:
        v = _number(node)
        return v is not None and abs(v - value) <= 1e-12 * max(1.0, abs(value))
    if isinstance(pattern, ast.Name) and pattern.id not in ("pi",):
        key = ast.dump(node)
        return bound.setdefault(pattern.id, key) == key
    if isinstance(pattern, ast.Name):  # pi: np.pi, math.pi, sp.pi, xp.pi, PI
        return _callee(node) in ("pi", "PI")
    if isinstance(pattern, ast.Call):
        if not isinstance(node, ast.Call) or _callee(pattern.func) != _callee(node.func):
            return False
        args = [a for a in node.args if not (isinstance(a, ast.Starred))]
        pargs = pattern.args
        if len(args) < len(pargs):
            return False
        return all(_matches(p, a, bound) for p, a in zip(pargs, args))
    if isinstance(pattern, ast.BinOp):
        # x ** 2 in a pattern also matches x * x
        if (
            isinstance(pattern.op, ast.Pow)
            and _number(pattern.right) == 2.0
            and isinstance(node, ast.BinOp)
            and isinstance(node.op, ast.Mult)
            and ast.dump(node.left) == ast.dump(node.right)
        ):
            return _matches(pattern.left, node.left, bound)
        return (
            isinstance(node, ast.BinOp)
            and type(node.op) is type(pattern.op)
            and _matches(pattern.left, node.left, bound)
            and _matches(pattern.right, node.right, bound)
        )
    if isinstance(pattern, ast.UnaryOp):
        return (
            isinstance(node, ast.UnaryOp)
            and type(node.op) is type(pattern.op)
            and _matches(pattern.operand, node.operand, bound)
        )
    return False


def _compiled() -> list[tuple[str, str, ast.expr]]:
    return [
        (quantity, text, ast.parse(text, mode="eval").body) for quantity, texts in PATTERNS.items() for text in texts
    ]


def _modules(root: Path):
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root.parent).as_posix()
        if rel.startswith(("fitlab/physics/", "fitlab/fits/")):
            continue
        yield rel, ast.parse(path.read_text(encoding="utf-8"), filename=rel)


def _physics_names(tree: ast.Module) -> set[str]:
    """The names a module binds to fitlab.physics or to what it imports from it."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[:2] == ["fitlab", "physics"]:
            out |= {a.asname or a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module == "fitlab":
            out |= {a.asname or a.name for a in node.names if a.name == "physics"}
    return out


def find_copies(root: Path) -> list[str]:
    """Every copy the two checks find under ``root`` (a fitlab/ folder), one line each."""
    patterns = _compiled()
    found = []
    for rel, tree in _modules(root):
        for node in ast.walk(tree):
            if isinstance(node, (ast.BinOp, ast.Call)):
                for quantity, text, pattern in patterns:
                    if _matches(pattern, node, {}):
                        found.append(f"{rel}:{node.lineno}: {quantity}: {text}")
        physics = _physics_names(tree)
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if node.name in GONE:
                    found.append(f"{rel}:{node.lineno}: def {node.name}: a helper of a copy fitlab.physics replaces")
                elif node.name in NAMES:
                    used = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
                    if not used & physics:
                        found.append(
                            f"{rel}:{node.lineno}: def {node.name}: a physics function that does not call "
                            "fitlab.physics"
                        )
    return found


def test_the_physics_is_defined_once():
    copies = find_copies(ROOT / "fitlab")
    assert not copies, "second definitions of fitlab.physics's formulas:\n" + "\n".join(copies)


def test_the_patterns_find_the_physics_itself():
    """Each pattern matches fitlab.physics or a copy it stands for: the check is not vacuous.  Here: every quantity
    has a pattern that matches fitlab/physics/ itself (the walk above leaves that folder out)."""
    patterns = _compiled()
    hits = set()
    for path in sorted((ROOT / "fitlab" / "physics").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.BinOp, ast.Call)):
                hits |= {q for q, _, p in patterns if _matches(p, node, {})}
    assert hits == set(PATTERNS), sorted(set(PATTERNS) - hits)


def test_a_pasted_copy_is_found(tmp_path):
    pkg = tmp_path / "fitlab" / "families" / "toy"
    pkg.mkdir(parents=True)
    (pkg / "copy.py").write_text(
        "import jax.numpy as jnp\n\n\ndef lam(t2):\n    return t2 / (2.0 * (1.0 + jnp.sqrt(1.0 + t2)))\n\n\n"
        "def phase_function(u):\n    return 2 * (jnp.sqrt((1 - u) * (1 + u)) - u * jnp.arccos(u)) / 3\n"
    )
    found = find_copies(tmp_path / "fitlab")
    assert any("Smith Lambda" in f for f in found) and any("phase function" in f for f in found)
    assert any("def phase_function" in f for f in found)


if __name__ == "__main__":
    lines = find_copies(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "fitlab")
    print("\n".join(lines))
    print(f"{len(lines)} found")
