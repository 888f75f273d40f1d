r"""Source files from a :class:`~fitlab.codegen.Program`, one emitter per language.

Each routine is printed as common subexpressions (sympy ``cse``) then one
return.  The emitters only lay out files (headers, signatures, the safe_pow
helper); all the maths is in the routines' expressions.  File names and
function names come from the program's ``name`` (``lambert_sphere`` below).

* C: ``lambert_sphere.h`` and ``lambert_sphere.c``, C99, libm only; every routine in
  double (``lambert_sphere_NAME``) and float (``lambert_sphere_NAME_f``).  The same
  files serve C++ (``extern "C"`` guards in the header) and CUDA: every function
  carries the qualifier macro ``LAMBERT_SPHERE_FN``, which is ``__host__ __device__``
  under nvcc (``__CUDACC__``) and empty otherwise (define it before including the
  header to choose another).  ``single_header=True`` gives one stb-style file
  instead, ``lambert_sphere.h``: the declarations, and the definitions in the one
  translation unit that defines ``LAMBERT_SPHERE_IMPLEMENTATION`` before including it.
* Python: ``lambert_sphere.py``, numpy only, every routine vectorised
  (broadcasting inputs; vectors are arrays with a last axis of 3).
* GLSL: ``lambert_sphere.glsl``, float functions ``lambert_sphere_NAME``
  (GLSL 3.30 / ES 3.00 and later); HLSL and Metal from the same shader emitter.
* Dr.Jit: ``lambert_sphere_drjit.py``, ``import drjit`` only: every routine as a function of Dr.Jit
  arrays of the caller's backend and precision, or of Python floats (Mitsuba's scalar variants); a
  material is a tuple of fields of its parameter's type (a Color3f: one material per channel).
"""

from __future__ import annotations

import heapq
import itertools
import textwrap
from dataclasses import dataclass

import sympy as sp

from fitlab import __version__
from fitlab.codegen._material import field_symbol
from fitlab.codegen._model import Material, Program, Routine, outputs
from fitlab.codegen._policy import SAFE_POW, unused_inputs
from fitlab.codegen._rewrites import rebuilt
from fitlab.codegen.names import LANGUAGE_NAMES
from fitlab.codegen.printers import CPrinter, DrJitPrinter, GLSLPrinter, MetalPrinter, NumpyPrinter
from fitlab.codegen.program import reproducible_sympy
from fitlab.forms.symbolic import safe_pow

__all__ = ["emit", "LANGUAGES"]


def _cse(routine: Routine):
    """Common subexpressions, then every non-atomic argument of a Max or Min in a temporary of its own:
    Max and Min print as conditionals (x < k ? k : x), which name their argument twice.  Returns (temps,
    value expression, [x, y, z] of the output vector or [])."""
    temps, exprs = _cse_many(outputs(routine), routine.name)
    return temps, exprs[0], exprs[1:]


#: :func:`_cse_many`'s results by the expressions' structure (:func:`_structure`): one routine is printed in six
#: languages, and in C in double and float, from the same expressions, and sympy's cse of a model takes seconds
_CSE_DONE: dict = {}


def _structure(exprs) -> tuple:
    """A key that tells apart any two expressions that could print differently: each node's class and its
    arguments' keys, each atom's class and its whole hashable content (a Float's precision, a symbol's
    assumptions: what ``==`` may not tell apart).  ``srepr`` would do, but sorts every sum and product."""
    memo: dict = {}

    def key(e):
        out = memo.get(id(e))
        if out is None:
            args = e.args
            out = (type(e), tuple(key(a) for a in args)) if args else (type(e), e._hashable_content())
            memo[id(e)] = out
        return out

    return tuple(key(e) for e in exprs)


def _cse_many(exprs, name: str):
    """:func:`_cse` of several expressions at once (their temporaries shared): (temps, expressions)."""
    exprs = tuple(exprs)
    key = _structure(exprs)
    done = _CSE_DONE.get(key)
    if done is None:
        if len(_CSE_DONE) >= 256:
            _CSE_DONE.pop(next(iter(_CSE_DONE)))
        done = _CSE_DONE[key] = _cse_computed(exprs)
    temps, out = done
    return list(temps), list(out)


def _named_in_order(found, reduced, names):
    """sympy's temporaries ``found`` renamed from ``names`` in an order of their own, and ``reduced`` with the new
    names: each step names, of the temporaries whose operands are all named, the one whose expression (with
    those names) sorts first by sympy's ``default_sort_key``.  The order of sympy's cse follows its traversal,
    which was seen to differ between runs of one program (the same temporaries, numbered otherwise, after
    other sympy work in the process); this order depends on the temporaries alone.  Renaming one real symbol
    for another leaves sympy nothing to re-order in a max or min: they are rebuilt unevaluated
    (:func:`fitlab.codegen.rebuilt`)."""
    value = dict(found)
    users: dict = {t: [] for t in value}
    waiting = {}
    for t, e in found:
        operands = [a for a in e.free_symbols if a in value]
        waiting[t] = len(operands)
        for a in operands:
            users[a].append(t)
    rename: dict = {}
    ready: list = []
    count = itertools.count()  # never reached: two temporaries with one expression would be one

    def push(t):
        e = rebuilt(value[t], lambda n: rename.get(n, n))
        heapq.heappush(ready, (sp.default_sort_key(e), next(count), t, e))

    for t, n in waiting.items():
        if n == 0:
            push(t)
    out = []
    while ready:
        _, _, t, e = heapq.heappop(ready)
        rename[t] = next(names)
        out.append((rename[t], e))
        for u in users[t]:
            waiting[u] -= 1
            if waiting[u] == 0:
                push(u)
    return out, [rebuilt(e, lambda n: rename.get(n, n)) for e in reduced]


def _cse_computed(given: tuple) -> tuple[tuple, tuple]:
    """What :func:`_cse_many` returns, computed: (temps, expressions), each a tuple."""
    names = sp.numbered_symbols("t", real=True)
    found, exprs = sp.cse(list(given), symbols=sp.numbered_symbols("cse", cls=sp.Dummy, real=True), order="canonical")
    temps, exprs = _named_in_order(found, exprs, names)
    out = []

    def temp(value):
        t = next(names)
        out.append((t, value))
        return t

    def hoist(e):
        if e.is_Atom:
            return e
        args = [hoist(a) for a in e.args]
        if isinstance(e, (sp.Max, sp.Min)):
            args = [a if a.is_Atom or a.is_number else temp(a) for a in args]
            others, consts = [a for a in args if not a.is_number], [a for a in args if a.is_number]
            if len(others) > 1 and (len(others) > 2 or consts):  # pairs, each in a temporary
                acc = others[0]
                for a in others[1:-1]:
                    acc = temp(e.func(acc, a))
                if not consts:
                    return e.func(acc, others[-1], *consts)
                return e.func(temp(e.func(acc, others[-1])), *consts)
        return e if all(a is b for a, b in zip(args, e.args)) else e.func(*args)

    conditions = {}  # a condition shared by several branches stays written where it is used
    for t, e in temps:
        e = hoist(e.xreplace(conditions))
        if isinstance(e, sp.logic.boolalg.Boolean):
            conditions[t] = e
            continue
        out.append((t, e))
    # sympy's cse is unannotated: pyright infers str among its reduced expressions, which are sympy expressions
    reduced = [hoist(e.xreplace(conditions)) for e in exprs]  # pyright: ignore[reportAttributeAccessIssue]
    return tuple(out), tuple(reduced)


#: the licence of generated source: fitlab's own (LICENSE), so that it may be dropped into any renderer
SPDX_LICENSE = "MIT"


def _banner(program: Program, lang: str, comment: str, command: str | None = None) -> str:
    lines = [
        f"SPDX-License-Identifier: {SPDX_LICENSE}",
        f"Generated by fitlab {__version__} ({command or f'fitlab codegen --lang {lang}'}); do not edit, regenerate.",
        *program.about,
        *([f"Model: {program.model[0]} ({program.model[1]})"] if program.model else []),
        *program.claim,
        *(
            [
                "From these fits (file, sha256, where read, the physics it was fitted to, and its error against its "
                "own target as fitlab codegen re-measured it on the target's validation set):"
            ]
            if program.sources and program.source_notes
            else []
        ),
        *(["From these fits (sha256):"] if program.sources and not program.source_notes else []),
        *(
            f"  {path}  {digest}" + (f"  {note}" if note else "")
            for (path, digest), note in itertools.zip_longest(program.sources, program.source_notes)
        ),
    ]
    return "\n".join(f"{comment} {line}".rstrip() for line in lines) + "\n"


def _wrap(doc: str, indent: str, width: int = 96) -> list[str]:
    return textwrap.wrap(doc, width=width, initial_indent=indent, subsequent_indent=indent)


# ---- C ----------------------------------------------------------------------


def _vector_names(routine: Routine, vector_index: str) -> dict:
    names = {}
    for v, comps in routine.vectors.items():
        for k, comp in enumerate(comps):
            names[comp] = vector_index.format(v=v, k=k, c="xyz"[k])
    return names


def _c_params(routine: Routine, scalar: str) -> str:
    params = [f"const {scalar} {a}[3]" if a in routine.vectors else f"{scalar} {a}" for a in routine.signature()]
    return ", ".join(params + ([f"{scalar} {routine.out}[3]"] if routine.out else []))


def _with_unused(value: str, r: Routine, printer, scalar_args: bool, skip=()) -> str:
    """``value`` plus 0 times each argument of ``r`` that it does not use, clamped into its domain
    (:func:`fitlab.codegen.unused_inputs`; none when ``scalar_args`` is false, names in ``skip``
    excepted): a NaN there gives NaN, and +-inf or any other number adds exactly 0, in every language."""
    if not scalar_args:
        return value
    zero = printer.doprint(sp.Float(0.0))
    terms = [f"{zero}*({printer.doprint(x)})" for x in unused_inputs(r) if str(x.free_symbols.pop()) not in skip]
    return " + ".join([value, *terms])


def _c_signature(routine: Routine, scalar: str, prefix: str, leading: str = "") -> str:
    suffix = "_f" if scalar == "float" else ""
    return f"{scalar} {prefix}{routine.name}{suffix}({leading}{_c_params(routine, scalar)})"


def _c_function(routine: Routine, scalar: str, prefix: str, qualifier: str, leading: str = "", names=None) -> str:
    """One routine as a C function; ``leading``: parameters before the routine's own (with their comma),
    ``names``: how further symbols read (a material's fields)."""
    suffix = "_f" if scalar == "float" else ""
    symbol_names = {**_vector_names(routine, "{v}[{k}]"), **(names or {})}
    printer = CPrinter(scalar, lambda n: f"{prefix}{n}{suffix}", symbol_names)
    temps, expr, vector = _cse(routine)
    body = [f"    const {scalar} {t} = {printer.doprint(e)};" for t, e in temps]
    body += [f"    {routine.out}[{k}] = {printer.doprint(e)};" for k, e in enumerate(vector)]
    body.append(f"    return {_with_unused(printer.doprint(expr), routine, printer, not routine.vectors)};")
    return f"{qualifier} {_c_signature(routine, scalar, prefix, leading)}\n{{\n" + "\n".join(body) + "\n}\n"


_MATERIAL_DOC = (
    "Per-material set-up: {prepare}({params}) fills the struct with every quantity that depends on "
    "{params} alone ({n} numbers){setups}; {evals} evaluate with it, so that a renderer prepares each "
    "material once and evaluates it many times. The _rgb variants take three materials (one per "
    "channel) and give three values."
)


def _material_doc(program: Program) -> str:
    m = program.material
    assert m is not None
    setups = "".join(f", {program.prefix}{name}({arg}) the same from {arg}" for name, arg, _ in m.setups)
    return _MATERIAL_DOC.format(
        prepare=program.prefix + m.prepare_name,
        params=", ".join(m.params),
        n=len(m.fields),
        setups=setups,
        evals=", ".join(program.prefix + r.name for r in m.evaluators),
    )


def _material_names(material: Material, access: str) -> dict:
    """{field symbol name: how the language reads field j} (``access`` formatted with j)."""
    return {field_symbol(j).name: access.format(j=j) for j in range(len(material.fields))}


def _c_material(program: Program, qualifier: str) -> tuple[list[str], list[str]]:
    """(declarations, definitions) of the material struct and its routines, double then float."""
    m, prefix = program.material, program.prefix
    assert m is not None
    decls, defs = ["\n/*\n" + "\n".join(_wrap(_material_doc(program), " * ")) + "\n */\n"], []
    for scalar, suffix in (("double", ""), ("float", "_f")):
        struct = f"{prefix}material{suffix}"
        decls.append(f"typedef struct {struct} {{ {scalar} k[{len(m.fields)}]; }} {struct};\n")
        params = ", ".join(f"{scalar} {a}" for a in m.params)
        sig = f"{struct} {prefix}{m.prepare_name}{suffix}({params})"
        decls.append(f"{qualifier} {sig};\n")
        printer = CPrinter(scalar, lambda n, s=suffix: f"{prefix}{n}{s}")
        temps, exprs = _cse_many(m.fields, m.prepare_name)
        body = [f"    {struct} m;"] + [f"    const {scalar} {t} = {printer.doprint(e)};" for t, e in temps]
        body += [f"    m.k[{j}] = {printer.doprint(e)};" for j, e in enumerate(exprs)]
        defs.append(f"\n{qualifier} {sig}\n{{\n" + "\n".join(body) + "\n    return m;\n}\n")
        for name, arg, routine in m.setups:
            sig = f"{struct} {prefix}{name}{suffix}({scalar} {arg})"
            decls.append(f"{qualifier} {sig};\n")
            defs.append(
                f"\n{qualifier} {sig}\n{{\n"
                f"    return {prefix}{m.prepare_name}{suffix}({prefix}{routine}{suffix}({arg}));\n}}\n"
            )
        for name, arg in ((m.prepare_name, ", ".join(m.params)), *((n, a) for n, a, _ in m.setups)):
            sig = f"void {prefix}{name}_rgb{suffix}(const {scalar} {arg}[3], {struct} m[3])"
            decls.append(f"{qualifier} {sig};\n")
            defs.append(
                f"\n{qualifier} {sig}\n{{\n    int k;\n    for (k = 0; k < 3; ++k) m[k] = "
                f"{prefix}{name}{suffix}({arg}[k]);\n}}\n"
            )
        for r in m.evaluators:
            leading = f"const {struct} *m, "
            if scalar == "double":
                decls.append("\n/*\n" + "\n".join(_wrap(r.doc, " * ")) + "\n */\n")
            decls.append(f"{qualifier} {_c_signature(r, scalar, prefix, leading)};\n")
            defs.append("\n" + _c_function(r, scalar, prefix, qualifier, leading, _material_names(m, "m->k[{j}]")))
            if r.out:  # a sampler: one direction per call, whichever channel the caller samples by
                continue
            args = ", ".join(r.signature())
            sig = f"void {prefix}{r.name}_rgb{suffix}(const {struct} m[3], {_c_params(r, scalar)}, {scalar} out[3])"
            decls.append(f"{qualifier} {sig};\n")
            defs.append(
                f"\n{qualifier} {sig}\n{{\n    int k;\n    for (k = 0; k < 3; ++k) out[k] = "
                f"{prefix}{r.name}{suffix}(m + k, {args});\n}}\n"
            )
    return decls, defs


def _c_files(program: Program, command: str | None = None, single_header: bool = False) -> dict[str, str]:
    prefix, base = program.prefix, program.name
    guard, qualifier, implementation = base.upper() + "_H", base.upper() + "_FN", base.upper() + "_IMPLEMENTATION"
    banner = "/*\n" + _banner(program, "c", " *", command) + " */\n"
    h = [banner, f"#ifndef {guard}\n#define {guard}\n\n"]
    h.append(f"/* {qualifier}: the qualifier of every function; __host__ __device__ under nvcc, so that CUDA kernels\n"
             f" * call them (define it before including this header to choose another). */\n"
             f"#ifndef {qualifier}\n#ifdef __CUDACC__\n#define {qualifier} __host__ __device__\n#else\n"
             f"#define {qualifier}\n#endif\n#endif\n\n"
             "#ifdef __cplusplus\nextern \"C\" {\n#endif\n")  # fmt: skip
    for r in program.routines:
        h.append("\n/*\n" + "\n".join(_wrap(r.doc, " * ")) + "\n */\n")
        for scalar in ("double", "float"):
            h.append(f"{qualifier} {_c_signature(r, scalar, prefix)};\n")
    material_decls, material_defs = _c_material(program, qualifier) if program.material else ([], [])
    h += material_decls
    h.append("\n#ifdef __cplusplus\n}\n#endif\n")
    body = ["#include <math.h>\n\n"]
    if any(r.expr.has(safe_pow) for r in program.routines):
        body.append(f"/* {_SAFE_POW_DOC} */\n")
        for scalar, suffix in (("double", ""), ("float", "_f")):
            text = CPrinter(scalar, str).doprint(SAFE_POW)
            body.append(
                f"static {qualifier} {scalar} {prefix}safe_pow{suffix}({scalar} x, {scalar} p) {{ return {text}; }}\n"
            )
    for scalar in ("double", "float"):
        for r in program.routines:
            body.append("\n" + _c_function(r, scalar, prefix, qualifier))
    body += material_defs
    if single_header:
        # stb style: the definitions once, in the translation unit that asks for them
        h.append(f"\n#endif /* {guard} */\n\n#ifdef {implementation}\n#ifndef {implementation}_DONE\n"
                 f"#define {implementation}_DONE\n\n#ifdef __cplusplus\nextern \"C\" {{\n#endif\n\n")  # fmt: skip
        h += body
        h.append(
            f"\n#ifdef __cplusplus\n}}\n#endif\n\n#endif /* {implementation}_DONE */\n#endif /* {implementation} */\n"
        )
        return {f"{base}.h": "".join(h)}
    h.append(f"\n#endif /* {guard} */\n")
    c = [banner, f'#include "{base}.h"\n\n', *body]
    return {f"{base}.h": "".join(h), f"{base}.c": "".join(c)}


# ---- GLSL -------------------------------------------------------------------


@dataclass(frozen=True)
class _Shading:
    """What a shading language changes in the one shader emitter: the file's extension and opening lines,
    the 3- and 4-vector types, and the printer (Metal: float literals carry the f suffix)."""

    extension: str
    vec3: str
    preamble: str
    vec4: str
    printer: type = GLSLPrinter


_SHADING = {
    "glsl": _Shading(
        "glsl",
        "vec3",
        "// Float functions for GLSL 3.30 / ES 3.00 and later; paste or #include after #version.\n"
        "// OpenGL ES has no default float precision in fragment shaders: this file sets highp there.\n"
        "#ifdef GL_ES\nprecision highp float;\n#endif\n\n",
        "vec4",
    ),
    "hlsl": _Shading(
        "hlsl",
        "float3",
        "// Float functions for HLSL (shader model 5 and later; DXC, FXC, glslang); #include into a shader.\n\n",
        "float4",
    ),
    "metal": _Shading(
        "metal",
        "float3",
        "// Float functions for the Metal Shading Language (2.0 and later); "
        "#include into a .metal file.\n"
        "#include <metal_stdlib>\nusing namespace metal;\n\n",
        "float4",
        MetalPrinter,
    ),
}


def _shading_files(program: Program, command: str | None, lang: str) -> dict[str, str]:
    """One shader source for GLSL, HLSL or Metal (:data:`_SHADING`): float functions, the same expressions."""
    sh = _SHADING[lang]
    prefix, base = program.prefix, program.name
    out = [
        _banner(program, lang, "//", command),
        sh.preamble,
        f"// {_SAFE_POW_DOC}\n",
        f"float {prefix}safe_pow(float x, float p) {{ return {sh.printer(str).doprint(SAFE_POW)}; }}\n",
        "// log(1 + x) and exp(x) - 1 without cancellation near x = 0 (Kahan's tricks; the language lacks both).\n",
        f"float {prefix}log1p(float x) {{ float u = {_one(sh)} + x; "
        f"return u == {_one(sh)} ? x : log(u) * x / (u - {_one(sh)}); }}\n",
        f"float {prefix}expm1(float x)\n{{\n    float u = exp(x);\n    if (u == {_one(sh)}) return x;\n"
        f"    if (u - {_one(sh)} == -{_one(sh)}) return -{_one(sh)};\n    return (u - {_one(sh)}) * x / log(u);\n}}\n",
    ]
    out += [_shading_function(r, sh, prefix) for r in program.routines]
    if program.material is not None:
        out += _shading_material(program, sh)
    return {f"{base}.{sh.extension}": "".join(out)}


def _shading_params(r: Routine, sh: _Shading) -> str:
    return ", ".join(f"{sh.vec3} {a}" if a in r.vectors else f"float {a}" for a in r.signature())


def _shading_function(r: Routine, sh: _Shading, prefix: str, leading: str = "", names=None) -> str:
    """One routine as a float function of the shading language, its doc comment first; ``leading``:
    parameters before the routine's own (with their comma), ``names``: how further symbols read."""
    printer = sh.printer(lambda n: prefix + n, {**_vector_names(r, "{v}.{c}"), **(names or {})})
    temps, expr, vector = _cse(r)
    body = [f"    float {t} = {printer.doprint(e)};" for t, e in temps]
    if vector:  # (x, y, z, value) in one vector: GLSL's out parameters have no C or Metal spelling in common
        body.append(f"    return {sh.vec4}({', '.join(printer.doprint(e) for e in (*vector, expr))});")
    else:
        body.append(f"    return {_with_unused(printer.doprint(expr), r, printer, True, names or {})};")
    kind = sh.vec4 if vector else "float"
    return (
        "\n"
        + "\n".join(_wrap(r.doc, "// "))
        + "\n"
        + f"{kind} {prefix}{r.name}({leading}{_shading_params(r, sh)})\n{{\n"
        + "\n".join(body)
        + "\n}\n"
    )


def _one(sh: _Shading) -> str:
    return sh.printer(str).doprint(sp.Float(1.0))


def _shading_material(program: Program, sh: _Shading) -> list[str]:
    """The struct, its set-up and the evaluators (structs by value); _rgb takes three materials."""
    m, prefix = program.material, program.prefix
    assert m is not None
    struct = f"{prefix}material"
    out = [
        "\n" + "\n".join(_wrap(_material_doc(program), "// ")) + "\n",
        f"struct {struct} {{ float k[{len(m.fields)}]; }};\n",
    ]
    printer = sh.printer(lambda n: prefix + n)
    temps, exprs = _cse_many(m.fields, m.prepare_name)
    body = [f"    {struct} m;"] + [f"    float {t} = {printer.doprint(e)};" for t, e in temps]
    body += [f"    m.k[{j}] = {printer.doprint(e)};" for j, e in enumerate(exprs)]
    params = ", ".join(f"float {a}" for a in m.params)
    out.append(f"\n{struct} {prefix}{m.prepare_name}({params})\n{{\n" + "\n".join(body) + "\n    return m;\n}\n")
    for name, arg, routine in m.setups:
        out.append(
            f"\n{struct} {prefix}{name}(float {arg}) {{ return {prefix}{m.prepare_name}({prefix}{routine}({arg})); }}\n"
        )
    for r in m.evaluators:
        out.append(_shading_function(r, sh, prefix, f"{struct} m, ", _material_names(m, "m.k[{j}]")))
        if r.out:
            continue
        params = _shading_params(r, sh)
        args = ", ".join(r.signature())
        out.append(
            f"{sh.vec3} {prefix}{r.name}_rgb({struct} r, {struct} g, {struct} b, {params})\n{{\n"
            f"    return {sh.vec3}({prefix}{r.name}(r, {args}), {prefix}{r.name}(g, {args}), "
            f"{prefix}{r.name}(b, {args}));\n}}\n"
        )
    return out


# ---- Python -----------------------------------------------------------------


_PY_HEADER = '''"""{doc}"""

import numpy


def _safe_pow(x, p):
    """{safe_pow_doc}"""
    x, p = numpy.asarray(x, dtype=float), numpy.asarray(p, dtype=float)
    return {safe_pow}

'''

#: what the safe_pow helper does, in every language (fitlab.codegen.SAFE_POW)
_SAFE_POW_DOC = "x^p for x > 0, 0 for x <= 0, NaN for NaN: the forms' safe_pow (keeps pow away from x <= 0)."


def _python_all(program: Program) -> str:
    """The ``__all__`` line of a generated Python module (numpy or Dr.Jit): every routine, then the
    per-material set-up and evaluators."""
    names = [r.name for r in program.routines]
    if program.material is not None:
        names += [
            program.material.prepare_name,
            *(n for n, _, _ in program.material.setups),
            *(r.name for r in program.material.evaluators),
        ]
    return "__all__ = [" + ", ".join(f'"{n}"' for n in names) + "]\n"


def _python_files(program: Program, command: str | None = None) -> dict[str, str]:
    header = _PY_HEADER.format(
        doc=program.doc, safe_pow_doc=_SAFE_POW_DOC, safe_pow=NumpyPrinter(str).doprint(SAFE_POW)
    )
    out = [_banner(program, "python", "#", command), header, _python_all(program)]
    out += [_python_function(r) for r in program.routines]
    if program.material is not None:
        out += _python_material(program)
    return {f"{program.name}.py": "".join(out)}


#: the sentence of _material_doc on the _rgb variants, which the Python emitters replace with their own way of RGB
_RGB_SENTENCE = "The _rgb variants take three materials (one per channel) and give three values."


def _python_setups(m) -> list[str]:
    """The set-ups other than prepare (prepare_c and the like) as Python functions: the same text in numpy and
    Dr.Jit, since each only composes two generated functions."""
    return [
        f'\n\ndef {name}({arg}):\n    """{m.prepare_name}({routine}({arg})): the material of {arg}."""\n'
        f"    return {m.prepare_name}({routine}({arg}))\n"
        for name, arg, routine in m.setups
    ]


def _python_material(program: Program) -> list[str]:
    """The per-material routines in numpy: a material is an array whose last axis holds the fields, so
    that materials of any shape (one per channel: (..., 3, fields)) broadcast against the inputs."""
    m = program.material
    assert m is not None
    doc = (
        _material_doc(program)
        .replace(program.prefix, "")
        .replace(
            _RGB_SENTENCE,
            "A material is an array with a last axis of the fields; for RGB prepare an array of three values "
            "(shape (..., 3)) and give the inputs a trailing axis (mu_i[..., None]).",
        )
    )
    params = ", ".join(m.params)
    temps, exprs = _cse_many(m.fields, m.prepare_name)
    printer = NumpyPrinter(lambda n: "_safe_pow" if n == "safe_pow" else n)
    lines = [
        f"\n\ndef {m.prepare_name}({params}):",
        '    """' + "\n".join(_wrap(doc, "    ", 92)).strip() + '"""',
        f"    {params} = {', '.join(f'numpy.asarray({a}, dtype=float)' for a in m.params)}",
    ]
    lines += [f"    {t} = {printer.doprint(e)}" for t, e in temps]
    fields = ", ".join(f"numpy.asarray({printer.doprint(e)}, dtype=float)" for e in exprs)
    lines.append(f"    return numpy.stack(numpy.broadcast_arrays({fields}), axis=-1)")
    out = ["\n".join(lines) + "\n", *_python_setups(m)]
    out += [_python_function(r, ("material",), _material_names(m, "material[..., {j}]")) for r in m.evaluators]
    return out


def _python_function(r: Routine, leading=(), names=None) -> str:
    """One routine as a numpy function; ``leading``: arguments before the routine's own, ``names``: how
    further symbols read (a material's fields)."""
    symbol_names = {**_vector_names(r, "{v}[..., {k}]"), **(names or {})}
    printer = NumpyPrinter(lambda n: "_safe_pow" if n == "safe_pow" else n, symbol_names)
    temps, expr, vector = _cse(r)
    sig = (*leading, *r.signature())
    lines = [f"\n\ndef {r.name}({', '.join(sig)}):", '    """' + "\n".join(_wrap(r.doc, "    ", 92)).strip() + '"""']
    lines.append(f"    {', '.join(sig)} = {', '.join(f'numpy.asarray({a}, dtype=float)' for a in sig)}")
    lines += [f"    {t} = {printer.doprint(e)}" for t, e in temps]
    if vector:
        # every output in the shape of all the inputs together (vectors and materials less their last axis)
        shapes = ", ".join(f"{a}.shape[:-1]" if a in r.vectors or a in leading else f"{a}.shape" for a in sig)
        values = ", ".join(printer.doprint(e) for e in (*vector, expr))
        lines.append(f"    shape = numpy.broadcast_shapes({shapes})")
        lines.append(f"    x, y, z, value = (numpy.broadcast_to(e, shape) for e in ({values}))")
        lines.append("    return numpy.stack((x, y, z), axis=-1), value.copy()")
        return "\n".join(lines) + "\n"
    # an input the result does not depend on must still broadcast into its shape (and pass its NaN on)
    lines.append(f"    return {_with_unused(printer.doprint(expr), r, printer, True, symbol_names)}")
    return "\n".join(lines) + "\n"


# ---- Dr.Jit -----------------------------------------------------------------


_DRJIT_DOC = """{about}

Generated by fitlab for Dr.Jit: ``import drjit`` only, no Mitsuba variant.  Every function takes Dr.Jit
arrays of one backend and precision (``drjit.llvm.ad.Float``, ``drjit.cuda.Float64``, Mitsuba's ``Float``
and ``Color3f`` of any variant, ...) or Python floats (Mitsuba's scalar variants), and computes in the
caller's type: the functions trace into the caller's kernel.  A vector argument (wi, wo) is a Dr.Jit
3-vector (``Array3f``, Mitsuba's ``Vector3f``) or a sequence of three components; a sampler returns
(its direction as a vector of the type of wi, its density).

A material (``prepare_c``, ``prepare``) is a tuple of fields, each of the type of its argument: prepared
from a Color3f (one value per channel), ``eval`` and ``eval_local`` give a Color3f for Float directions.
Conditionals are ``dr.select`` (both branches evaluated); NaN and domain policy as in every language.
"""

_DRJIT_HEADER = '''"""{doc}"""

import drjit as dr


def _safe_pow(x, p):
    """{safe_pow_doc}"""
    return {safe_pow}


def _log1p(x):
    """log(1 + x) without cancellation near x = 0 (Kahan's trick; Dr.Jit has no log1p)."""
    u = 1.0 + x
    return dr.select(u == 1.0, x, dr.log(u) * x / dr.select(u == 1.0, 1.0, u - 1.0))


def _expm1(x):
    """exp(x) - 1 without cancellation near x = 0 (Kahan's trick; Dr.Jit has no expm1)."""
    u = dr.exp(x)
    ratio = (u - 1.0) * x / dr.select((u == 1.0) | (u == 0.0), 1.0, dr.log(u))
    return dr.select(u == 1.0, x, dr.select(u - 1.0 == -1.0, -1.0, ratio))


def _vector(like, x, y, z):
    """(x, y, z) as a 3-vector of the type of ``like`` when that is a Dr.Jit array, else a tuple."""
    return type(like)(x, y, z) if dr.is_array_v(like) else (x, y, z)

'''


def _drjit_name(n: str) -> str:
    return {"safe_pow": "_safe_pow", "expm1": "_expm1", "log1p": "_log1p"}.get(n, n)


def _drjit_files(program: Program, command: str | None = None) -> dict[str, str]:
    """``NAME_drjit.py``: every routine (and the per-material set-up) as a function of Dr.Jit arrays."""
    doc = _DRJIT_DOC.format(about=" ".join(program.about[:1]) or program.name)
    header = _DRJIT_HEADER.format(doc=doc, safe_pow_doc=_SAFE_POW_DOC, safe_pow=DrJitPrinter(str).doprint(SAFE_POW))
    out = [_banner(program, "drjit", "#", command), header, _python_all(program)]
    out += [_drjit_function(r) for r in program.routines]
    if program.material is not None:
        out += _drjit_material(program)
    return {f"{program.name}_drjit.py": "".join(out)}


def _drjit_material(program: Program) -> list[str]:
    """The per-material routines: a material is a tuple of fields, each of the type of the parameter."""
    m = program.material
    assert m is not None
    doc = (
        _material_doc(program)
        .replace(program.prefix, "")
        .replace(
            _RGB_SENTENCE,
            "A material is a tuple of fields of the type of the argument: prepare a Color3f (one value per channel) "
            "for RGB, and the evaluators give a Color3f.",
        )
    )
    params = ", ".join(m.params)
    temps, exprs = _cse_many(m.fields, m.prepare_name)
    printer = DrJitPrinter(_drjit_name)
    lines = [f"\n\ndef {m.prepare_name}({params}):", '    """' + "\n".join(_wrap(doc, "    ", 92)).strip() + '"""']
    lines += [f"    {t} = {printer.doprint(e)}" for t, e in temps]
    lines.append("    return (")
    lines += [f"        {printer.doprint(e)}," for e in exprs]
    lines.append("    )")
    out = ["\n".join(lines) + "\n", *_python_setups(m)]
    out += [_drjit_function(r, ("material",), _material_names(m, "material[{j}]")) for r in m.evaluators]
    return out


def _drjit_function(r: Routine, leading=(), names=None) -> str:
    """One routine as a function of Dr.Jit arrays; ``leading``: arguments before the routine's own, ``names``:
    how further symbols read (a material's fields)."""
    symbol_names = {**_vector_names(r, "{v}[{k}]"), **(names or {})}
    printer = DrJitPrinter(_drjit_name, symbol_names)
    temps, expr, vector = _cse(r)
    sig = (*leading, *r.signature())
    lines = [f"\n\ndef {r.name}({', '.join(sig)}):", '    """' + "\n".join(_wrap(r.doc, "    ", 92)).strip() + '"""']
    lines += [f"    {t} = {printer.doprint(e)}" for t, e in temps]
    if vector:
        x, y, z = (printer.doprint(e) for e in vector)
        lines.append(f"    return _vector({next(iter(r.vectors))}, {x}, {y}, {z}), {printer.doprint(expr)}")
        return "\n".join(lines) + "\n"
    # an input the result does not depend on still passes its NaN on (as in every language)
    lines.append(f"    return {_with_unused(printer.doprint(expr), r, printer, True, symbol_names)}")
    return "\n".join(lines) + "\n"


_PRINTERS = {
    "c": _c_files,
    "python": _python_files,
    **{lang: (lambda program, command=None, lang=lang: _shading_files(program, command, lang)) for lang in _SHADING},
    "drjit": _drjit_files,
}
#: {language: its printer}, in the order of :data:`fitlab.codegen.LANGUAGE_NAMES` (the names' one owner)
LANGUAGES = {lang: _PRINTERS[lang] for lang in LANGUAGE_NAMES}


def emit(program: Program, lang: str, command: str | None = None, single_header: bool = False) -> dict[str, str]:
    """{file name: source text} of ``program`` in ``lang`` (one of :data:`LANGUAGES`).  ``command``: the
    command the banner names (default ``fitlab codegen --lang LANG``); ``single_header``: C as one stb-style
    header (see the module docstring)."""
    if lang not in LANGUAGES:
        raise ValueError(f"unknown language {lang!r}; choose one of {', '.join(LANGUAGES)}")
    if single_header and lang != "c":
        raise ValueError("a single header is a C option")
    reproducible_sympy()
    if lang == "c":
        return _c_files(program, command, single_header)
    return LANGUAGES[lang](program, command)
