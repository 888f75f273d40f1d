"""The registered Mitsuba 3 plugin ``lambert_sphere`` (fitlab.families.lambert_sphere.mitsuba.plugin) in
scalar_rgb and llvm_ad_rgb: loading from a dict and from XML, a render against the generated C integrated over
each pixel, the white furnace at c = 1 against the directional albedo by quadrature of the generated C, RGB
channels against single-channel renders, bitmap textures, mi.traverse, and Mitsuba's chi-square test of the
sampler.  Each variant renders in a subprocess (an LLVM that cannot compile Dr.Jit's code aborts the process,
and a variant is a process-wide setting); the references are computed here."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

from fitlab.codegen import emit, load_program  # noqa: E402
from fitlab.codegen.native import build, compiler  # noqa: E402
from fitlab.families.lambert_sphere.mitsuba.render import pixel_geometry  # noqa: E402

SIZE, SPP = 12, 16  # the directional-light renders (the only noise: where in the pixel each sample falls)
#: the furnace's pixels and samples per pixel by variant: the scalar one calls Python for every sample
FURNACE = {"scalar_rgb": (12, 64), "llvm_ad_rgb": (32, 1024)}
LIGHT = np.array([0.55, 0.3, 0.78]) / np.linalg.norm([0.55, 0.3, 0.78])  # off both image axes
KD = (0.8, 0.5, 0.2)
CHI2 = ((0.3, 0.1), (0.9, 0.5), (1.0, 1.0))  # (c, mu_i)

_RENDERS = textwrap.dedent("""
    import json, sys
    import numpy as np
    import drjit as dr
    import mitsuba as mi
    from fitlab.families.lambert_sphere.mitsuba.render import render_bsdf, render_sphere
    variant, out = sys.argv[1], sys.argv[2]
    light, kd = np.array(json.loads(sys.argv[3])), json.loads(sys.argv[4])
    size, spp, fsize, fspp = (int(a) for a in sys.argv[5:9])
    res = {}
    rgb = {"type": "lambert_sphere", "reflectance": {"type": "rgb", "value": kd}}
    res["rgb"] = render_bsdf(rgb, light, size, spp, seed=1, variant=variant)
    for k, v in enumerate(kd):
        res[f"grey{k}"] = render_sphere("lambert_sphere", v, light, size, spp, seed=1, variant=variant)
    res["furnace"] = render_sphere("lambert_sphere", 1.0, None, fsize, fspp, seed=2, variant=variant)
    texture = {"type": "bitmap", "bitmap": mi.Bitmap(np.tile(np.array(kd, np.float32), (2, 2, 1))), "raw": True,
               "filter_type": "nearest"}
    res["texture"] = render_bsdf({"type": "lambert_sphere", "reflectance": texture}, light, size, spp, seed=1)
    from fitlab.families.lambert_sphere.mitsuba.plugin import load_drjit_module
    c = [load_drjit_module().c_of_kd(v) for v in kd]
    res["albedo"] = render_bsdf({"type": "lambert_sphere", "albedo": {"type": "rgb", "value": c}}, light, size, spp, seed=1)
    # XML, with the plugin registered (render_bsdf did it in this variant)
    xml = mi.load_string('<bsdf version="3.0.0" type="lambert_sphere"><rgb name="reflectance" value="%s"/></bsdf>'
                         % ", ".join(map(str, kd)))
    res["xml"] = render_bsdf(xml, light, size, spp, seed=1)
    meta = {"variant": mi.variant(), "repr": str(xml)}
    if variant.startswith("llvm"):
        # a texture that varies: two texels side by side, kd 0.8 and 0.3 (u < 1/2 and u >= 1/2)
        two = np.array([[[0.8] * 3, [0.3] * 3]], np.float32)
        texture = {"type": "bitmap", "bitmap": mi.Bitmap(two), "raw": True, "filter_type": "nearest"}
        res["varying"] = render_bsdf({"type": "lambert_sphere", "reflectance": texture}, light, size, spp, seed=1)
        res["grey_03"] = render_sphere("lambert_sphere", 0.3, light, size, spp, seed=1)
        # the furnace in colour: the sampler follows the mean kd, each channel must still be its own albedo
        res["furnace_rgb"] = render_bsdf(rgb, None, fsize, fspp, seed=3)
        # mi.traverse: a grey sphere turned into the RGB one
        from fitlab.families.lambert_sphere.mitsuba.render import sphere_scene
        scene = sphere_scene({"type": "lambert_sphere", "reflectance": {"type": "rgb", "value": [0.5] * 3}}, light, size, spp)
        params = mi.traverse(scene)
        keys = [k for k in params.keys() if k.endswith("reflectance.value")]
        params[keys[0]] = mi.Color3f(*kd)
        params.update()
        res["traversed"] = np.array(mi.render(scene, seed=1))
        meta["traverse_keys"] = keys
        # differentiable rendering: d(sum of the image)/d(reflectance) by AD through the plugin against a
        # central difference of renders with the adjoint pass's seed (seed_grad; a delta light: the same
        # samples give the same image, so the difference is exact but for rounding)
        grey = lambda v: mi.Color3f(v, v, v)  # noqa: E731
        params[keys[0]] = grey(0.5)
        dr.enable_grad(params[keys[0]])
        params.update()
        dr.backward(dr.sum(mi.render(scene, params, seed=1, seed_grad=2), axis=None))
        meta["grad"] = float(np.sum(np.array(dr.grad(params[keys[0]]))))
        total = {}
        for v in (0.49, 0.51):
            params[keys[0]] = grey(v)
            params.update()
            total[v] = float(np.array(mi.render(scene, params, seed=2)).sum())
        meta["fd"] = (total[0.51] - total[0.49]) / 0.02
        # Mitsuba's chi-square test of sample() against pdf(), through its BSDFAdapter
        from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain
        points = json.loads(sys.argv[9])
        meta["chi2"] = []
        for c, mu in points:
            wi = [float(np.sqrt(1 - mu * mu)), 0.0, float(mu)]
            sample, pdf = BSDFAdapter("lambert_sphere", {"type": "lambert_sphere", "albedo": c}, wi=wi)
            test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf, sample_dim=3,
                                 sample_count=200000, res=101, ires=4, seed=int(100 * c + 10 * mu))
            meta["chi2"].append({"c": c, "mu_i": mu, "passed": bool(test.run(0.01, test_count=len(points), quiet=True)),
                                 "messages": test.messages[-400:]})
    np.savez(out, **res)
    print(json.dumps(meta))
""")


def _start(variant, folder):
    """The renders of ``variant`` started in a subprocess: (process, its output file)."""
    out = folder / f"{variant}.npz"
    args = [variant, str(out), json.dumps(LIGHT.tolist()), json.dumps(list(KD)), str(SIZE), str(SPP),
            *(str(n) for n in FURNACE[variant]), json.dumps(CHI2)]  # fmt: skip
    proc = subprocess.Popen([sys.executable, "-c", _RENDERS, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env={**os.environ, "PYTHONHASHSEED": "0"})  # fmt: skip
    return proc, out


def _finish(variant, proc, out):
    """(images, metadata) of a started subprocess; a skip with the reason where the llvm variant cannot run."""
    try:
        stdout, stderr = proc.communicate(timeout=900)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail(f"the {variant} renders did not finish in 900 s")
    if proc.returncode != 0:
        reason = (stderr.strip().splitlines() or ["?"])[-1]
        if variant.startswith("llvm") and ("LLVM" in stderr or "libLLVM" in stderr):
            pytest.skip(f"Mitsuba's llvm variant is unavailable here (tools/install-system-packages.sh): {reason}")
        pytest.fail(stderr[-3000:])
    return dict(np.load(out)), json.loads(stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def started(tmp_path_factory):
    """Both variants' renders, started at once (two processes) while this one builds the C reference."""
    folder = tmp_path_factory.mktemp("renders")
    procs = {variant: _start(variant, folder) for variant in FURNACE}
    yield procs
    for proc, _ in procs.values():
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.fixture(scope="module", params=list(FURNACE))
def rendered(request, started):
    if compiler() is not None:
        request.getfixturevalue("native")  # built here while the renders run
    return request.param, *_finish(request.param, *started[request.param])


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    """The generated C (unoptimised: the reference needs its values, not its speed; it builds in a second)."""
    if compiler() is None:
        pytest.skip("no C compiler")
    program = load_program()
    return build(emit(program, "c"), program, tmp_path_factory.mktemp("c"), flags=("-std=c99", "-O0"))


def _frame(n):
    """Local frames (t, b, n) at normals n (k x 3): any tangent serves an isotropic BRDF."""
    t = np.cross(n, [0.3, 0.5, 0.1])
    t /= np.linalg.norm(t, axis=-1, keepdims=True)
    return t, np.cross(n, t), n


def expected_image(native, kd, size, sub=6, extent=1.05):
    """Pixel averages (and their spread) of f(wi, wo) cos(theta_i), unit irradiance from LIGHT, seen from +z: the
    generated C's eval_local with the material prepare(kd), on sub x sub points per pixel."""
    fine = pixel_geometry(size * sub, extent).reshape(-1, 3)
    on = ~np.isnan(fine[:, 0])
    t, b, n = _frame(fine[on])
    local = lambda v: np.stack([t @ v, b @ v, n @ v], axis=-1)  # noqa: E731
    wi, wo = local(LIGHT), local(np.array([0.0, 0.0, 1.0]))
    material = native("prepare", np.array([kd]))
    f = native("eval_local", material, np.zeros(on.sum(), dtype=np.int64), wi, wo)
    values = np.zeros(len(fine))
    values[on] = f * np.maximum(wi[:, 2], 0.0)
    blocks = values.reshape(size, sub, size, sub)
    return blocks.mean(axis=(1, 3)), blocks.std(axis=(1, 3))


def directional_albedo(native, mu_o, c=1.0, n=64):
    """a(mu_o) = int f(mu_i, mu_o, phi) mu_i dmu_i dphi by Gauss-Legendre quadrature of the generated C's brdf."""
    x, w = np.polynomial.legendre.leggauss(n)
    mu_i, wmu = 0.5 * (x + 1), 0.5 * w
    phi, wphi = np.pi * (x + 1), np.pi * w  # phi in [0, 2 pi]
    out = []
    for m in np.atleast_1d(mu_o):
        a, p = np.meshgrid(mu_i, phi, indexing="ij")
        f = native("brdf", a.ravel(), np.full(a.size, m), np.cos(p).ravel(), np.full(a.size, c)).reshape(a.shape)
        out.append(np.einsum("i,j,ij,i->", wmu, wphi, f, mu_i))
    return np.array(out)


@pytest.mark.e2e
def test_render_matches_the_generated_c_integrated_over_each_pixel(rendered, native):
    variant, img, meta = rendered
    assert meta["variant"] == variant
    n = pixel_geometry(SIZE)
    for k, kd in enumerate(KD):
        want, spread = expected_image(native, kd, SIZE)
        inner = (np.nan_to_num(n[..., 2]) > 0.5) & (want > 0.05 * want.max())  # covered, lit pixels
        assert inner.sum() > 30
        got = img["rgb"][..., k]
        # a pixel is the mean of SPP uniformly placed samples: within 4 standard errors of the pixel average
        tol = 4 * spread[inner] / np.sqrt(SPP) + 1e-4 * want[inner]
        assert np.all(np.abs(got[inner] - want[inner]) < tol), (variant, kd)
        assert np.median(np.abs(got[inner] - want[inner]) / want[inner]) < 0.01
        mirrored = want[::-1, ::-1]
        assert np.max(np.abs(got[inner] - mirrored[inner]) / mirrored[inner]) > 0.1  # the test sees orientation


@pytest.mark.e2e
def test_rgb_channels_are_the_single_channel_renders_and_textures_agree(rendered):
    variant, img, meta = rendered
    for k in range(3):
        # the same samples (same seed, a delta light): the same numbers up to float rounding
        np.testing.assert_allclose(img["rgb"][..., k], img[f"grey{k}"], rtol=1e-5, atol=1e-7)
        # a bitmap of one colour (prepared at every lookup) equals the uniform colour (prepared once)
        np.testing.assert_allclose(img["texture"][..., k], img["rgb"][..., k], rtol=1e-5, atol=1e-7)
        # albedo c = c_of_kd(kd) directly equals reflectance kd
        np.testing.assert_allclose(img["albedo"][..., k], img["rgb"][..., k], rtol=1e-5, atol=1e-7)
        np.testing.assert_array_equal(img["xml"][..., k], img["rgb"][..., k])
    assert "LambertSphereBSDF" in meta["repr"] and "reflectance" in meta["repr"]


@pytest.mark.e2e
def test_white_furnace_at_c_1_is_the_directional_albedo(rendered, native):
    """kd = 1 (c = c_of_kd(1) = 1) under a constant environment of radiance 1: each pixel is the directional
    albedo of the runtime model at its mu_o (averaged over the pixel), by quadrature of the generated C."""
    variant, img, meta = rendered
    residual, albedo_nodes = _furnace_residual(native, img["furnace"], 1.0)
    assert np.all(np.abs(albedo_nodes[1:] - 1.0) < 3e-4)  # the runtime model conserves energy (docs/model.md)
    se = residual.std(ddof=1) / np.sqrt(residual.size)  # pixels are independent estimates
    assert abs(residual.mean()) < 4 * se, (variant, residual.mean(), se)
    assert se < (5e-3 if variant == "scalar_rgb" else 5e-4)  # the test resolves a bias of 2 % (scalar), 0.2 % (llvm)
    assert np.all(np.abs(residual) < 6 * residual.std(ddof=1))


def _furnace_residual(native, image, c):
    """Pixel values minus the directional albedo at c (averaged over each pixel), on pixels with mu_o > 0.3."""
    sub, size = 4, len(image)
    fine = pixel_geometry(size * sub)
    mu_nodes = np.linspace(0.0, 1.0, 41)
    albedo_nodes = directional_albedo(native, mu_nodes, c)
    a = np.interp(np.nan_to_num(fine[..., 2]), mu_nodes, albedo_nodes)
    want = a.reshape(size, sub, size, sub).mean(axis=(1, 3))
    inner = np.nan_to_num(pixel_geometry(size)[..., 2]) > 0.3
    return image[inner] - want[inner], albedo_nodes


@pytest.mark.e2e
def test_furnace_in_colour_each_channel_is_its_own_albedo(rendered, native):
    """RGB kd (0.8, 0.5, 0.2) in the furnace: the sampler draws by the c of the mean kd, and each channel's
    weight f_r cos/p stays unbiased (pixels against the directional albedo at that channel's c)."""
    variant, img, meta = rendered
    if variant != "llvm_ad_rgb":
        pytest.skip("run in llvm_ad_rgb only (the scalar variant shares the code and costs seconds per render)")
    for k, kd in enumerate(KD):
        c = float(native("c_of_kd", np.array([kd]))[0])
        residual, _ = _furnace_residual(native, img["furnace_rgb"][..., k], c)
        se = residual.std(ddof=1) / np.sqrt(residual.size)
        assert abs(residual.mean()) < 4 * se, (kd, residual.mean(), se)


@pytest.mark.e2e
def test_a_texture_that_varies_traverse_and_gradients(rendered):
    variant, img, meta = rendered
    if variant != "llvm_ad_rgb":
        pytest.skip("run in llvm_ad_rgb only (the scalar variant shares the code and costs seconds per render)")
    # every lit pixel shows one of the two texels' uniform renders, or (on the seam) a mix of them
    lo = np.minimum(img["grey0"], img["grey_03"])
    hi = np.maximum(img["grey0"], img["grey_03"])
    got = img["varying"][..., 0]
    assert np.all((got >= lo - 1e-6) & (got <= hi + 1e-6))
    lit = hi > 0.05 * hi.max()
    near = lambda a: np.isclose(got, a, rtol=1e-5, atol=1e-7) & lit  # noqa: E731
    assert near(img["grey0"]).sum() > 10 and near(img["grey_03"]).sum() > 10
    assert meta["traverse_keys"] == ["sphere.bsdf.reflectance.value"]
    np.testing.assert_allclose(img["traversed"], img["rgb"], rtol=1e-5, atol=1e-7)
    assert np.isfinite(meta["grad"]) and meta["grad"] == pytest.approx(meta["fd"], rel=1e-4)


@pytest.mark.e2e
def test_mitsuba_chi2_accepts_the_plugin_sampler(rendered):
    """Mitsuba's chi-square test (BSDFAdapter on the registered plugin: sample() against pdf(), with its Sidak
    correction for the three points at significance 0.01)."""
    variant, img, meta = rendered
    if variant != "llvm_ad_rgb":
        pytest.skip("mitsuba.chi2 needs a vectorised variant")
    assert [[r["c"], r["mu_i"]] for r in meta["chi2"]] == [list(p) for p in CHI2]
    failed = [r for r in meta["chi2"] if not r["passed"]]
    assert not failed, failed


def test_plugin_errors_in_this_process():
    """One line for both parameters at once, a polarized variant, a module that is not generated Dr.Jit code."""
    from fitlab.families.lambert_sphere.mitsuba.plugin import PluginError, load_drjit_module, register
    from fitlab.resources import packaged_fits

    mi.set_variant("scalar_rgb")
    register()
    with pytest.raises(Exception, match="reflectance .* or albedo .*, not both"):
        mi.load_dict({"type": "lambert_sphere", "reflectance": 0.5, "albedo": 0.5})
    with pytest.raises(PluginError, match="not a generated Dr.Jit module"):
        load_drjit_module(packaged_fits() / "generated" / "lambert_sphere.py")
    with pytest.raises(PluginError, match="no generated Dr.Jit module"):
        load_drjit_module(packaged_fits() / "generated" / "missing_drjit.py")
    mi.set_variant("scalar_spectral_polarized")
    try:
        with pytest.raises(PluginError, match="no polarized form"):
            register()
    finally:
        mi.set_variant("scalar_rgb")


@pytest.mark.benchmark
def test_bench_render_measures_both_variants():
    """``fitlab bench render --quick --json`` (a benchmark: figures, not assertions on time): the plugin and
    Mitsuba's diffuse in scalar_rgb, and in llvm_ad_rgb where it runs."""
    res = subprocess.run([sys.executable, "-m", "fitlab", "bench", "render", "--quick", "--json", "--quiet"],
                         capture_output=True, text=True, timeout=900)  # fmt: skip
    assert res.returncode == 0, res.stderr[-2000:]
    out = json.loads(res.stdout)["results"]
    variants = ["scalar_rgb"] + ([] if out["llvm_problem"] else ["llvm_ad_rgb"])
    names = {f"{label}/{v}" for label in ("lambert_sphere (plugin)", "diffuse (Mitsuba)") for v in variants}
    assert set(out["rows"]) == names
    assert all(r["samples_per_s"] > 0 for r in out["rows"].values())
