#!/usr/bin/env python3
"""Runs a penumbra benchmark workload on Mesa's llvmpipe, for a same-machine comparison.

The workload comes from penumbra itself (`penumbra bench frame --export DIR` or
`penumbra bench raster --export DIR`), so both renderers draw the same triangles with the same
matrices, targets and state: the spheres frame (a 32-bit float depth pass from the light with
polygon offset and no culling, then the camera pass with a hardware 2x2 comparison or 25 of
them on a 5x5 grid, or the classic PCSS shader of `penumbra bench frame --mode pcss`, or the
variance shadow map of `--mode vsm`: moments (z, z^2) into a two-channel f32 target, a 5-tap box
blur each way, Chebyshev's bound on the bilinear moments), or random triangles (colour + depth,
or depth only). Clip-space depth is
[0, 1] and window y points down (glClipControl), as in penumbra.

Not part of penumbra (which uses no system graphics library): a measuring tool. It needs
Mesa's EGL (Debian: libegl-mesa0, libgl1-mesa-dri) and `pip install moderngl`.

    python3 tools/llvmpipe_bench.py DIR --threads 2 [--reps 10] [--out image.png]

Prints median milliseconds per pass (glFinish around each) and, on its last line, one JSON
object with the keys of `penumbra bench ... --json`.
"""
import argparse
import ctypes
import json
import os
import statistics
import struct
import sys
import time
import zlib


# The 16-point Poisson disk commonly used with PCSS (penumbra's `kernel::POISSON16`).
POISSON16 = [
    (-0.94201624, -0.39906216), (0.94558609, -0.76890725), (-0.094184101, -0.92938870),
    (0.34495938, 0.29387760), (-0.91588581, 0.45771432), (-0.81544232, -0.87912464),
    (-0.38277543, 0.27676845), (0.97484398, 0.75648379), (0.44323325, -0.97511554),
    (0.53742981, -0.47373420), (-0.26496911, -0.41893023), (0.79197514, 0.19090188),
    (-0.24188840, 0.99706507), (-0.81409955, 0.91437590), (0.19984126, 0.78641367),
    (0.14383161, -0.14100790),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir", help="folder written by penumbra bench frame|raster --export")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--reps", type=int, default=10)
    ap.add_argument("--out", help="write the final colour image (PNG)")
    a = ap.parse_args()
    # llvmpipe reads these when the context is created.
    os.environ["LP_NUM_THREADS"] = str(a.threads)
    os.environ["GALLIUM_DRIVER"] = "llvmpipe"
    os.environ.setdefault("EGL_PLATFORM", "surfaceless")
    try:
        import moderngl
    except ImportError:
        sys.exit("llvmpipe_bench: needs moderngl (pip install moderngl) and Mesa's EGL (libegl-mesa0, libgl1-mesa-dri)")
    try:
        with open(os.path.join(a.dir, "workload.json")) as f:
            w = json.load(f)
        with open(os.path.join(a.dir, "vertices.f32"), "rb") as f:
            vbytes = f.read()
        with open(os.path.join(a.dir, "indices.u32"), "rb") as f:
            ibytes = f.read()
    except (OSError, ValueError) as e:
        sys.exit(f"llvmpipe_bench: {a.dir} is not a workload written by penumbra bench ... --export: {e}")
    if w.get("kind") not in ("frame", "raster") or len(ibytes) % 12 or len(vbytes) % (4 * w["floats_per_vertex"]):
        sys.exit(f"llvmpipe_bench: {a.dir}: unexpected workload layout {w}")
    tris = len(ibytes) // 12

    try:
        ctx = moderngl.create_standalone_context(backend="egl", require=450)
    except Exception as e:  # moderngl raises plain Exception when EGL or the driver is missing
        sys.exit(f"llvmpipe_bench: no OpenGL 4.5 context from Mesa's EGL ({e}); install libegl-mesa0 libgl1-mesa-dri")
    gl = ctypes.CDLL("libOpenGL.so.0")
    GL_UPPER_LEFT, GL_ZERO_TO_ONE = 0x8CA2, 0x935F
    gl.glClipControl(GL_UPPER_LEFT, GL_ZERO_TO_ONE)
    renderer = ctx.info["GL_RENDERER"]
    version = ctx.info["GL_VERSION"]

    def depth32f(size):
        """A depth texture with 32-bit float storage (moderngl's default is 24-bit)."""
        t = ctx.depth_texture(size)
        GL_TEXTURE_2D, GL_DEPTH_COMPONENT32F, GL_DEPTH_COMPONENT, GL_FLOAT = 0x0DE1, 0x8CAC, 0x1902, 0x1406
        gl.glBindTexture(GL_TEXTURE_2D, t.glo)
        gl.glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, size[0], size[1], 0, GL_DEPTH_COMPONENT, GL_FLOAT, None)
        fmt = ctypes.c_int(0)
        gl.glGetTexLevelParameteriv(GL_TEXTURE_2D, 0, 0x1003, ctypes.byref(fmt))  # GL_TEXTURE_INTERNAL_FORMAT
        assert fmt.value == GL_DEPTH_COMPONENT32F, hex(fmt.value)
        return t

    vbo = ctx.buffer(vbytes)
    ibo = ctx.buffer(ibytes)
    ctx.enable(moderngl.DEPTH_TEST)
    ctx.depth_func = "<"
    passes = []  # (name, callable)

    if w["kind"] == "frame":
        S, W, H = w["map"], w["width"], w["height"]
        # The depth pass; for VSM it also writes the moments of its fragments' depth (the
        # depth test keeps the nearest, as penumbra's moments come from its depth map).
        depth_prog = ctx.program(
            vertex_shader="""#version 450
            uniform mat4 light_vp;
            in vec3 pos;
            void main() { gl_Position = light_vp * vec4(pos, 1.0); }""",
            fragment_shader="""#version 450
            out vec2 m;
            void main() { float z = gl_FragCoord.z; m = vec2(z, z * z); }"""
            if w["mode"] == "vsm"
            else """#version 450
            void main() {}""",
        )
        depth_prog["light_vp"].write(struct.pack("16f", *w["light_vp"]))
        if w["mode"] == "pcf2":
            taps = "shadow = texture(map, vec3(uv, l.z));"
        elif w["mode"] == "vsm":
            # penumbra's `vsm_shadow`: the blurred moments read bilinearly, Chebyshev's bound.
            min_var = float(w["vsm"]["min_variance"])
            taps = (
                "vec2 m = texture(moments, uv).rg; float mu = m.x;"
                " if (l.z <= mu) { shadow = 1.0; } else {"
                f" float var = max(m.y - mu * mu, {min_var!r}); float d = l.z - mu;"
                " shadow = var / (var + d * d); }"
            )
        elif w["mode"] == "pcss":
            # penumbra's `pcss_shadow`: 16 nearest raw-depth taps of the Poisson disk at 16
            # texels, blockers nearer than z - 0.0015, radius clamp((ref - mean) * 400, 1, 16)
            # texels, 16 hardware 2x2 comparisons on the same disk at that radius.
            disk = ", ".join(f"vec2({x!r}, {y!r})" for x, y in POISSON16)
            taps = (
                f"const vec2 P[16] = vec2[16]({disk});"
                f" vec2 texel = vec2(1.0 / {float(S)!r});"
                " float ref = l.z - 0.0015; float sum = 0.0; int found = 0;"
                " for (int i = 0; i < 16; i++) {"
                " float d = texture(raw, uv + P[i] * (16.0 * texel.x)).r;"
                " if (d < ref) { sum += d; found++; } }"
                " if (found == 0) { shadow = 1.0; } else {"
                " float r = clamp((ref - sum / float(found)) * 400.0, 1.0, 16.0);"
                " for (int i = 0; i < 16; i++) { shadow += texture(map, vec3(uv + P[i] * (r * texel.x), l.z)); }"
                " shadow /= 16.0; }"
            )
        else:
            # Offsets must be constant expressions: the 25 taps unrolled.
            taps = (
                " ".join(
                    f"shadow += textureOffset(map, vec3(uv, l.z), ivec2({i}, {j}));"
                    for j in range(-2, 3)
                    for i in range(-2, 3)
                )
                + " shadow /= 25.0;"
            )
        main_prog = ctx.program(
            vertex_shader="""#version 450
            uniform mat4 camera_vp; uniform mat4 light_vp;
            in vec3 pos; in vec3 normal; in vec3 albedo;
            out vec3 n; out vec3 l; out vec3 alb;
            void main() {
                gl_Position = camera_vp * vec4(pos, 1.0);
                n = normal; l = (light_vp * vec4(pos, 1.0)).xyz; alb = albedo;
            }""",
            fragment_shader="""#version 450
            uniform sampler2DShadow map; uniform sampler2D raw; uniform sampler2D moments;
            uniform vec3 to_light;
            in vec3 n; in vec3 l; in vec3 alb; out vec4 color;
            void main() {
                float ndl = max(dot(normalize(n), to_light), 0.0);
                vec2 uv = vec2(l.x * 0.5 + 0.5, 0.5 - l.y * 0.5);
                float shadow = 0.0;
                %s
                color = vec4(alb * (0.15 + 0.85 * ndl * shadow), 1.0);
            }"""
            % taps,
        )
        main_prog["camera_vp"].write(struct.pack("16f", *w["camera_vp"]))
        main_prog["light_vp"].write(struct.pack("16f", *w["light_vp"]))
        main_prog["to_light"].write(struct.pack("3f", *w["to_light"]))
        shadow = depth32f((S, S))
        shadow.compare_func = "<="
        shadow.filter = (moderngl.LINEAR, moderngl.LINEAR)
        shadow.repeat_x = shadow.repeat_y = False
        shadow_fbo = ctx.framebuffer(depth_attachment=shadow)
        raw = None
        if w["mode"] == "pcss":
            raw = ctx.sampler(
                texture=shadow,
                filter=(moderngl.NEAREST, moderngl.NEAREST),
                compare_func="",
                repeat_x=False,
                repeat_y=False,
            )
        color = ctx.texture((W, H), 4)
        color_fbo = ctx.framebuffer(color_attachments=[color], depth_attachment=depth32f((W, H)))
        moments = blurred = None
        if w["mode"] == "vsm":
            moments = ctx.texture((S, S), 2, dtype="f4")
            shadow_fbo = ctx.framebuffer(color_attachments=[moments], depth_attachment=shadow)
            # The separable 5-tap box blur: texel fetches clamped to the edge, each weighted
            # 0.2, summed from left to right (top to bottom).
            taps_each = int(w["vsm"]["blur_taps"])
            r = taps_each // 2
            blur_src = """#version 450
            uniform sampler2D src; uniform ivec2 dir; out vec2 m;
            void main() {
                ivec2 p = ivec2(gl_FragCoord.xy); ivec2 last = textureSize(src, 0) - 1;
                vec2 acc = vec2(0.0);
                for (int k = -%d; k <= %d; k++) { acc += texelFetch(src, clamp(p + dir * k, ivec2(0), last), 0).rg * 0.2; }
                m = acc;
            }""" % (r, r)
            blur_prog = ctx.program(
                vertex_shader="""#version 450
                void main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2); gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }""",
                fragment_shader=blur_src,
            )
            tmp = ctx.texture((S, S), 2, dtype="f4")
            blurred = ctx.texture((S, S), 2, dtype="f4")
            for t in (moments, tmp, blurred):
                t.filter = (moderngl.NEAREST, moderngl.NEAREST)
                t.repeat_x = t.repeat_y = False
            blurred.filter = (moderngl.LINEAR, moderngl.LINEAR)
            tmp_fbo = ctx.framebuffer(color_attachments=[tmp])
            blurred_fbo = ctx.framebuffer(color_attachments=[blurred])
            blur_vao = ctx.vertex_array(blur_prog, [])
        depth_vao = ctx.vertex_array(depth_prog, [(vbo, "3f 6x4", "pos")], ibo, index_element_size=4)
        main_vao = ctx.vertex_array(
            main_prog, [(vbo, "3f 3f 3f", "pos", "normal", "albedo")], ibo, index_element_size=4
        )
        cc = [c / 255.0 for c in w["clear_color"]]

        # The camera pass culls what penumbra's does (`camera_cull`; older exports: none).
        # penumbra's front faces are counter-clockwise in NDC, and so are GL's under
        # glClipControl's upper-left origin (checked: the culled image matches penumbra's as
        # closely as the unculled one, 0.03 % of pixels off by more than 8 of 255).
        camera_cull = w.get("camera_cull", "none")

        def depth_pass():
            ctx.disable(moderngl.CULL_FACE)
            shadow_fbo.use()
            # Moments of the cleared depth 1 where nothing is drawn.
            shadow_fbo.clear(1.0, 1.0, 0.0, 0.0, depth=1.0)
            ctx.polygon_offset = tuple(w["polygon_offset"])
            depth_vao.render(moderngl.TRIANGLES)

        def blur_pass():
            ctx.disable(moderngl.DEPTH_TEST)
            ctx.disable(moderngl.CULL_FACE)
            for src, fbo, d in ((moments, tmp_fbo, (1, 0)), (tmp, blurred_fbo, (0, 1))):
                fbo.use()
                src.use(0)
                blur_prog["src"].value = 0
                blur_prog["dir"].value = d
                blur_vao.render(moderngl.TRIANGLES, vertices=3)
            ctx.enable(moderngl.DEPTH_TEST)

        def main_pass():
            if camera_cull == "none":
                ctx.disable(moderngl.CULL_FACE)
            else:
                ctx.front_face = "ccw"
                ctx.cull_face = camera_cull
                ctx.enable(moderngl.CULL_FACE)
            color_fbo.use()
            color_fbo.clear(*cc, depth=1.0)
            ctx.polygon_offset = (0.0, 0.0)
            if "map" in main_prog:  # not read by the VSM shader
                shadow.use(0)
                main_prog["map"].value = 0
            if raw is not None:
                # The same depth texture, read without comparison (nearest, clamped).
                raw.use(1)
                main_prog["raw"].value = 1
            if blurred is not None:
                blurred.use(2)
                main_prog["moments"].value = 2
            main_vao.render(moderngl.TRIANGLES)

        passes = [("depth pass", depth_pass)]
        if w["mode"] == "vsm":
            passes.append(("blur", blur_pass))
        if w["mode"] != "depth":
            passes.append(("main pass", main_pass))
    else:
        W, H = w["width"], w["height"]
        colored = w["mode"] == "color"
        prog = ctx.program(
            vertex_shader="""#version 450
            in vec4 pos; in vec4 col; out vec4 c;
            void main() { gl_Position = pos; c = col; }""",
            fragment_shader="""#version 450
            in vec4 c; out vec4 color;
            void main() { color = c; }"""
            if colored
            else """#version 450
            void main() {}""",
        )
        depth = depth32f((W, H))
        color = ctx.texture((W, H), 4) if colored else None
        fbo = ctx.framebuffer(color_attachments=[color] if colored else [], depth_attachment=depth)
        vao = ctx.vertex_array(
            prog, [(vbo, "4f 4f", "pos", "col")] if colored else [(vbo, "4f 4x4", "pos")], ibo, index_element_size=4
        )

        def draw():
            fbo.use()
            fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
            vao.render(moderngl.TRIANGLES)

        passes = [("draw", draw)]

    times = {name: [] for name, _ in passes}
    frame = []
    for rep in range(2 + a.reps):  # two warm-up frames, as penumbra's bench does
        ctx.finish()
        f0 = time.perf_counter()
        for name, run in passes:
            t0 = time.perf_counter()
            run()
            ctx.finish()
            if rep >= 2:
                times[name].append((time.perf_counter() - t0) * 1e3)
        if rep >= 2:
            frame.append((time.perf_counter() - f0) * 1e3)
    med = {name: statistics.median(v) for name, v in times.items()}
    mf = statistics.median(frame)
    print(f"{renderer}, {version}, LP_NUM_THREADS={a.threads}: {w['kind']} {w['mode']}, {tris} triangles")
    for name, ms in med.items():
        print(f"{name:11} {ms:8.2f} ms  (min {min(times[name]):.2f})")
    print(f"frame:      {mf:8.2f} ms (median of {len(frame)})")
    if a.out and color is not None:
        write_png(a.out, color.width, color.height, color.read())
    out = {"renderer": renderer, "threads": a.threads, "triangles": tris, "kind": w["kind"], "mode": w["mode"]}
    if w["kind"] == "frame":
        out.update(ms_depth_pass=med["depth pass"], ms_main_pass=med.get("main pass", 0.0), ms_frame=mf)
        if "blur" in med:
            out.update(ms_prefilter=med["blur"])
    else:
        out.update(ms=mf, mtri_per_s=tris / mf / 1e3)
    print(json.dumps(out))


def write_png(path, width, height, rgba):
    """An RGBA8 image as PNG (rows top to bottom, as glClipControl's upper-left origin stores them)."""
    rows = b"".join(b"\0" + rgba[y * width * 4 : (y + 1) * width * 4] for y in range(height))
    chunk = lambda tag, data: struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(rows, 6)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


if __name__ == "__main__":
    sys.exit(main())
