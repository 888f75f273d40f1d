"""The names of a fit of one's own table: what an input, a fitted column or a form may be called, so that every
language codegen prints can use the name (the keywords and types of C, C++, GLSL, HLSL, Metal and Python)."""

from __future__ import annotations

import keyword
import re

from fitlab.fit.user._limits import UserDataError

__all__ = ["RESERVED", "RESERVED_INPUTS", "PARAMETER", "check_name", "not_registered"]

_IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")  # of at most fit_limits().name characters
PARAMETER = re.compile(r"^a[0-9]+$")
_TEMPORARY = re.compile(r"^t[0-9]+$")  # generated code names its common subexpressions t0, t1, ...

#: names an input, a fitted column or a form may not have: keywords and types of the languages codegen prints
#: (C, C++ for Metal, GLSL, HLSL, Python), and the modules generated Python imports
RESERVED = frozenset(
    """
auto break case char const continue default do double else enum extern float for goto if inline int long register
restrict return short signed sizeof static struct switch typedef union unsigned void volatile while bool true false
class namespace new delete this template typename using public private protected virtual operator friend try catch
throw explicit mutable constexpr decltype nullptr alignas alignof noexcept static_assert thread_local char16_t
char32_t wchar_t export asm and or not xor bitand bitor compl
attribute uniform varying layout centroid flat smooth noperspective patch sample subroutine in out inout invariant
precise discard lowp mediump highp precision vec2 vec3 vec4 ivec2 ivec3 ivec4 bvec2 bvec3 bvec4 uvec2 uvec3 uvec4
dvec2 dvec3 dvec4 mat2 mat3 mat4 uint half float2 float3 float4 float3x3 float4x4 half2 half3 half4 min16float
texture sampler2D sampler3D samplerCube cbuffer tbuffer groupshared technique pass string vector matrix
kernel device constant thread threadgroup metal main numpy dr drjit math safe_pow log1p expm1
""".split()
) | frozenset(keyword.kwlist)
#: names an input may not have besides: the functions generated code calls (an argument of that name would
#: hide the function) and the parser's constants
RESERVED_INPUTS = frozenset(
    """
abs acos asin atan atan2 ceil clamp cos cosh cross degrees distance dot exp exp2 floor fma fmod fract inversesqrt
length log log2 max min mix mod normalize pow radians round sign sin sinh smoothstep sqrt step tan tanh trunc
saturate lerp rsqrt frac Abs Max Min pi E
""".split()
)


def check_name(name, what: str) -> str:
    """``name`` if it can name an input, a fitted column or a form (an identifier of at most 64 characters
    that generated code can use: not a reserved word (:data:`RESERVED`; for an input :data:`RESERVED_INPUTS`
    too), not a parameter name a<digits>, not a generated temporary t<digits>); else :class:`UserDataError`."""
    from fitlab.store import fit_limits

    longest = fit_limits().name
    if not isinstance(name, str) or not _IDENTIFIER.match(name) or len(name) > longest:
        raise UserDataError(
            f"{what} {str(name)[:70]!r}{'...' if len(str(name)) > 70 else ''} is not a name fitlab can use: a "
            f"letter, then letters, digits or _ (at most {longest}); rename it"
        )
    if PARAMETER.match(name):
        raise UserDataError(
            f"{what} {name!r} is named like a parameter (a0, a1, ... are the form's parameters); rename it"
        )
    if _TEMPORARY.match(name) or name in RESERVED or (what == "input" and name in RESERVED_INPUTS):
        raise UserDataError(f"{what} {name!r} is a reserved word of a language fitlab generates; rename it")
    return name


def not_registered(target: str) -> None:
    from fitlab.core import targets

    registered = targets().get(target)
    if registered is not None:
        raise UserDataError(
            f"the fitted column is called {target}, like fitlab's built-in target {target} "
            f"({registered.family}); rename it so that its fit is never taken for that target's"
        )
