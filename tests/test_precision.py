"""``import fitlab`` leaves JAX's global configuration as it was; fitlab's own JAX work still runs in float64.

Each check runs in a fresh interpreter: the pytest process's JAX configuration
may have been changed by other tests."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

_SCRIPT = r"""
import json, sys
import numpy as np
import fitlab, fitlab.core, fitlab.fit.refit, fitlab.families.lambert_sphere
import fitlab.families.lambert_sphere.mc
import jax, jax.numpy as jnp

out = {"x64_after_import": bool(jax.config.jax_enable_x64), "dtype_after_import": str(jnp.ones(1).dtype)}
from fitlab.core import float64
from fitlab.fit.refit import refit

res = refit("m")
out["params"] = res.record["params"]
out["theta_dtype"] = str(np.asarray(res.fit.theta).dtype)
out["dtype_after_refit"] = str(jnp.ones(1).dtype)

from fitlab.families.lambert_sphere.mc.phase_sampling import p_true
from fitlab.families.lambert_sphere.mc.transport import WalkConfig, run_round

out["p_true_dtype"] = str(p_true(np.linspace(-1.0, 1.0, 5)).dtype)
r = run_round(WalkConfig(phase="three_term", slots=64), 1, (0,), 0.9, 0.5, 2_000)
out["mc_escape_dtype"] = str(np.asarray(r["escape"]).dtype)
out["mc_escape"] = float(np.asarray(r["escape"]).sum()) / 2_000
out["dtype_after_mc"] = str(jnp.ones(1).dtype)
with float64():
    out["dtype_inside_context"] = str(jnp.ones(1).dtype)
out["dtype_after_context"] = str(jnp.ones(1).dtype)
out["x64_at_end"] = bool(jax.config.jax_enable_x64)
print("RESULT " + json.dumps(out))
"""


def _run(code: str, **env) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), JAX_PLATFORMS="cpu",
               **env)  # fmt: skip
    env.pop("JAX_ENABLE_X64", None)
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    line = next(ln for ln in reversed(out.stdout.splitlines()) if ln.startswith("RESULT "))
    return json.loads(line[len("RESULT ") :])


@pytest.mark.e2e
def test_import_keeps_float32_default_and_fits_stay_float64():
    r = _run(_SCRIPT)
    # the user's default survives import fitlab (and the family, the refit and the Monte Carlo modules)
    assert r["x64_after_import"] is False and r["dtype_after_import"] == "float32"
    # the refit still runs in float64: the committed fit, to 1e-8 relative
    committed = json.loads((ROOT / "fitlab" / "fits" / "m.json").read_text())["params"]
    assert set(r["params"]) == set(committed)
    for name, value in committed.items():
        np.testing.assert_allclose(r["params"][name], value, rtol=1e-8, err_msg=name)
    assert r["theta_dtype"] == "float64"
    # ... and the Monte Carlo too
    assert r["p_true_dtype"] == "float64" and r["mc_escape_dtype"] == "float64"
    assert 0.0 < r["mc_escape"] < 1.0
    # float64 only inside fitlab's calls: the global default is float32 after each of them
    assert r["dtype_after_refit"] == r["dtype_after_mc"] == r["dtype_after_context"] == "float32"
    assert r["dtype_inside_context"] == "float64"
    assert r["x64_at_end"] is False


def test_a_user_float64_setting_is_kept():
    code = ("import jax; jax.config.update('jax_enable_x64', True)\n"
            "import fitlab, fitlab.core, fitlab.fit.refit, fitlab.families.lambert_sphere\n"
            "from fitlab.core import float64\n"
            "with float64():\n    pass\n"
            "import json, jax.numpy as jnp\n"
            "print('RESULT ' + json.dumps({'x64': bool(jax.config.jax_enable_x64),\n"
            "                              'dtype': str(jnp.ones(1).dtype)}))")  # fmt: skip
    assert _run(code) == {"x64": True, "dtype": "float64"}
