// deformlab report: sortable tables and the mesh viewer (WebGL; a 2D
// canvas, flat-shaded and depth-sorted, where WebGL is unavailable).
// Written for this report; it loads nothing from the network.
(function () {
  "use strict";
  var errors = 0;
  window.addEventListener("error", function () {
    errors += 1;
    document.body.setAttribute("data-errors", String(errors));
  });

  // ---- sortable tables: click (or Enter on) a heading --------------------
  function cellValue(td) {
    var v = td.getAttribute("data-v");
    if (v === null || v === "") return null;
    var x = parseFloat(v);
    return isNaN(x) ? null : x;
  }
  function sortTable(table, col, th) {
    var body = table.tBodies[0];
    var rows = Array.prototype.slice.call(body.rows);
    var dir = th.getAttribute("aria-sort") === "ascending" ? -1 : 1;
    rows.sort(function (a, b) {
      var ca = a.cells[col], cb = b.cells[col];
      if (!ca || !cb) return 0;
      var x = cellValue(ca), y = cellValue(cb);
      if (x !== null && y !== null) return dir * (x - y);
      if (x !== null) return -1; // numbers before blanks, either way
      if (y !== null) return 1;
      return dir * ca.textContent.localeCompare(cb.textContent);
    });
    rows.forEach(function (r) { body.appendChild(r); });
    Array.prototype.forEach.call(th.parentNode.cells, function (h) { h.removeAttribute("aria-sort"); });
    th.setAttribute("aria-sort", dir === 1 ? "ascending" : "descending");
  }
  Array.prototype.forEach.call(document.querySelectorAll("table.sortable"), function (t) {
    if (!t.tHead) return;
    Array.prototype.forEach.call(t.tHead.rows[0].cells, function (th, i) {
      th.tabIndex = 0;
      th.addEventListener("click", function () { sortTable(t, i, th); });
      th.addEventListener("keydown", function (e) {
        if (e.key === "Enter" || e.key === " ") { e.preventDefault(); sortTable(t, i, th); }
      });
    });
  });

  // ---- meshes -------------------------------------------------------------
  function bytes(b64) {
    var s = atob(b64), a = new Uint8Array(s.length);
    for (var i = 0; i < s.length; i++) a[i] = s.charCodeAt(i);
    return a;
  }
  // Positions centred on the bounding box and scaled into the unit sphere;
  // smooth vertex normals (area-weighted face normals).
  function decode(m) {
    var pos = new Float32Array(bytes(m.pos).buffer);
    var tri = new Uint32Array(bytes(m.tri).buffer);
    var rgb = bytes(m.rgb);
    var n = pos.length / 3, i, k;
    var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    for (i = 0; i < n; i++) for (k = 0; k < 3; k++) {
      lo[k] = Math.min(lo[k], pos[3 * i + k]); hi[k] = Math.max(hi[k], pos[3 * i + k]);
    }
    var c = [0, 1, 2].map(function (k) { return (lo[k] + hi[k]) / 2; }), r = 0;
    for (i = 0; i < n; i++) {
      var d = 0;
      for (k = 0; k < 3; k++) { pos[3 * i + k] -= c[k]; d += pos[3 * i + k] * pos[3 * i + k]; }
      r = Math.max(r, d);
    }
    r = Math.sqrt(r) || 1;
    for (i = 0; i < pos.length; i++) pos[i] /= r;
    var nrm = new Float32Array(pos.length);
    for (var f = 0; f < tri.length; f += 3) {
      var a = 3 * tri[f], b = 3 * tri[f + 1], e = 3 * tri[f + 2];
      var ux = pos[b] - pos[a], uy = pos[b + 1] - pos[a + 1], uz = pos[b + 2] - pos[a + 2];
      var vx = pos[e] - pos[a], vy = pos[e + 1] - pos[a + 1], vz = pos[e + 2] - pos[a + 2];
      var nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      [a, b, e].forEach(function (v) { nrm[v] += nx; nrm[v + 1] += ny; nrm[v + 2] += nz; });
    }
    for (i = 0; i < n; i++) {
      var l = Math.hypot(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]) || 1;
      for (k = 0; k < 3; k++) nrm[3 * i + k] /= l;
    }
    return { pos: pos, tri: tri, rgb: rgb, nrm: nrm };
  }

  // Rotation (yaw about y, then pitch about x) as a row-major 3×3 matrix.
  function rotation(yaw, pitch) {
    var cy = Math.cos(yaw), sy = Math.sin(yaw), cp = Math.cos(pitch), sp = Math.sin(pitch);
    return [cy, 0, sy, sp * sy, cp, -sp * cy, -cp * sy, sp, cp * cy];
  }
  var FOV = 0.6; // tan of half the vertical field of view

  // One WebGL context for the page (browsers cap live contexts at ~16): it
  // draws off screen, and each viewer copies the picture to its own canvas.
  function glRenderer(canvas) {
    var gl = canvas.getContext("webgl", { antialias: true, preserveDrawingBuffer: true });
    if (!gl) return null;
    function shader(type, src) {
      var s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    }
    var prog = gl.createProgram();
    gl.attachShader(prog, shader(gl.VERTEX_SHADER,
      "attribute vec3 p; attribute vec3 n; attribute vec3 c; uniform mat3 R; uniform float d; uniform float f; uniform float asp;" +
      "varying vec3 vc; varying vec3 vn;" +
      "void main() { vec3 q = R * p; float z = d - q.z; gl_Position = vec4(q.x / (f * asp), q.y / f, 0.5 * (z - d) * z, z); vn = R * n; vc = c; }"));
    gl.attachShader(prog, shader(gl.FRAGMENT_SHADER,
      "precision mediump float; varying vec3 vc; varying vec3 vn;" +
      "void main() { float l = abs(normalize(vn).z); gl_FragColor = vec4(vc * (0.35 + 0.65 * l), 1.0); }"));
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
    var loc = { p: gl.getAttribLocation(prog, "p"), n: gl.getAttribLocation(prog, "n"), c: gl.getAttribLocation(prog, "c") };
    return {
      mode: "webgl",
      canvas: canvas,
      // One interleaved vertex per triangle corner: position, normal, colour.
      upload: function (m) {
        var data = new Float32Array(m.tri.length * 9);
        for (var i = 0; i < m.tri.length; i++) {
          var v = m.tri[i], o = 9 * i;
          for (var k = 0; k < 3; k++) {
            data[o + k] = m.pos[3 * v + k];
            data[o + 3 + k] = m.nrm[3 * v + k];
            data[o + 6 + k] = m.rgb[3 * v + k] / 255;
          }
        }
        var buf = gl.createBuffer();
        gl.bindBuffer(gl.ARRAY_BUFFER, buf);
        gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
        return { buf: buf, count: m.tri.length };
      },
      draw: function (b, cam, w, h) {
        canvas.width = w;
        canvas.height = h;
        gl.viewport(0, 0, w, h);
        gl.clearColor(1, 1, 1, 1);
        gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
        gl.enable(gl.DEPTH_TEST);
        gl.useProgram(prog);
        var R = rotation(cam.yaw, cam.pitch);
        // GLSL matrices are column-major: pass the transpose of row-major R.
        gl.uniformMatrix3fv(gl.getUniformLocation(prog, "R"), false,
          [R[0], R[3], R[6], R[1], R[4], R[7], R[2], R[5], R[8]]);
        gl.uniform1f(gl.getUniformLocation(prog, "d"), cam.dist);
        gl.uniform1f(gl.getUniformLocation(prog, "f"), FOV);
        gl.uniform1f(gl.getUniformLocation(prog, "asp"), w / h);
        gl.bindBuffer(gl.ARRAY_BUFFER, b.buf);
        [["p", 0], ["n", 3], ["c", 6]].forEach(function (a) {
          gl.enableVertexAttribArray(loc[a[0]]);
          gl.vertexAttribPointer(loc[a[0]], 3, gl.FLOAT, false, 36, a[1] * 4);
        });
        gl.drawArrays(gl.TRIANGLES, 0, b.count);
      }
    };
  }
  var shared;
  function sharedGl() {
    if (shared === undefined) {
      try { shared = glRenderer(document.createElement("canvas")); } catch (e) { shared = null; }
    }
    return shared;
  }

  // Without WebGL: flat-shaded triangles, far to near, on a 2D canvas.
  function draw2d(ctx, mesh, cam, w, h) {
    var s = Math.min(w, h) / 2;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, w, h);
    var R = rotation(cam.yaw, cam.pitch), p = mesh.pos, n = p.length / 3;
    var sx = new Float32Array(n), sy = new Float32Array(n), sz = new Float32Array(n);
    for (var i = 0; i < n; i++) {
      var x = p[3 * i], y = p[3 * i + 1], z = p[3 * i + 2];
      var qx = R[0] * x + R[1] * y + R[2] * z, qy = R[3] * x + R[4] * y + R[5] * z, qz = R[6] * x + R[7] * y + R[8] * z;
      var depth = cam.dist - qz, k = s / (FOV * depth);
      sx[i] = w / 2 + qx * k; sy[i] = h / 2 - qy * k; sz[i] = depth;
    }
    var t = mesh.tri, nf = t.length / 3, order = new Array(nf);
    for (var f = 0; f < nf; f++) order[f] = f;
    order.sort(function (a, b) {
      return (sz[t[3 * b]] + sz[t[3 * b + 1]] + sz[t[3 * b + 2]]) - (sz[t[3 * a]] + sz[t[3 * a + 1]] + sz[t[3 * a + 2]]);
    });
    ctx.lineWidth = 0.5;
    for (var j = 0; j < nf; j++) {
      var g = order[j], vs = [t[3 * g], t[3 * g + 1], t[3 * g + 2]];
      var nz = 0, col = [0, 0, 0];
      vs.forEach(function (v) {
        nz += Math.abs(R[6] * mesh.nrm[3 * v] + R[7] * mesh.nrm[3 * v + 1] + R[8] * mesh.nrm[3 * v + 2]) / 3;
        for (var c = 0; c < 3; c++) col[c] += mesh.rgb[3 * v + c] / 3;
      });
      var l = 0.35 + 0.65 * nz;
      ctx.fillStyle = ctx.strokeStyle = "rgb(" + Math.round(col[0] * l) + "," + Math.round(col[1] * l) + "," + Math.round(col[2] * l) + ")";
      ctx.beginPath();
      ctx.moveTo(sx[vs[0]], sy[vs[0]]);
      ctx.lineTo(sx[vs[1]], sy[vs[1]]);
      ctx.lineTo(sx[vs[2]], sy[vs[2]]);
      ctx.closePath();
      ctx.fill();
      ctx.stroke();
    }
  }

  var drawn = 0;
  function viewer(canvas) {
    var data = JSON.parse(document.getElementById(canvas.getAttribute("data-meshes")).textContent);
    var ctx = canvas.getContext("2d");
    var meshes = {}, uploads = {}, current = data.first || 0;
    var home = { yaw: 0, pitch: 0, dist: 1.8 };
    var cam = { yaw: home.yaw, pitch: home.pitch, dist: home.dist };
    function paint() {
      if (!meshes[current]) meshes[current] = decode(data.meshes[current]);
      var gl = sharedGl(), w = canvas.width, h = canvas.height;
      if (gl) {
        if (!uploads[current]) uploads[current] = gl.upload(meshes[current]);
        gl.draw(uploads[current], cam, w, h);
        ctx.clearRect(0, 0, w, h);
        ctx.drawImage(gl.canvas, 0, 0);
      } else {
        draw2d(ctx, meshes[current], cam, w, h);
      }
      if (!canvas.hasAttribute("data-drawn")) {
        drawn += 1;
        document.body.setAttribute("data-viewers-drawn", String(drawn));
      }
      canvas.setAttribute("data-drawn", gl ? "webgl" : "2d");
      canvas.setAttribute("data-mesh", data.meshes[current].label);
    }
    var pending = false;
    function redraw() {
      if (pending) return;
      pending = true;
      window.requestAnimationFrame(function () { pending = false; paint(); });
    }
    var pick = document.querySelector("select.mesh-pick[data-canvas='" + canvas.id + "']");
    if (pick) pick.addEventListener("change", function () { current = parseInt(pick.value, 10); paint(); });
    var drag = null;
    canvas.addEventListener("pointerdown", function (e) {
      drag = { x: e.clientX, y: e.clientY };
      canvas.setPointerCapture(e.pointerId);
    });
    canvas.addEventListener("pointermove", function (e) {
      if (!drag) return;
      cam.yaw += (e.clientX - drag.x) * 0.01;
      cam.pitch = Math.max(-1.5, Math.min(1.5, cam.pitch + (e.clientY - drag.y) * 0.01));
      drag = { x: e.clientX, y: e.clientY };
      redraw();
    });
    canvas.addEventListener("pointerup", function () { drag = null; });
    canvas.addEventListener("wheel", function (e) {
      e.preventDefault();
      cam.dist = Math.max(1.1, Math.min(8, cam.dist * Math.exp(e.deltaY * 0.001)));
      redraw();
    }, { passive: false });
    canvas.addEventListener("dblclick", function () {
      cam.yaw = home.yaw; cam.pitch = home.pitch; cam.dist = home.dist;
      redraw();
    });
    paint();
  }

  // A viewer decodes and draws its mesh when it first comes into view.
  var canvases = Array.prototype.slice.call(document.querySelectorAll("canvas.mesh"));
  function start(canvas) {
    if (canvas.getAttribute("data-started")) return;
    canvas.setAttribute("data-started", "1");
    viewer(canvas);
  }
  // Those in view at load draw at once (a screenshot taken at load shows
  // them); the others when scrolled to.
  canvases = canvases.filter(function (c) {
    var r = c.getBoundingClientRect();
    if (r.bottom >= -200 && r.top <= window.innerHeight + 200) { start(c); return false; }
    return true;
  });
  if ("IntersectionObserver" in window) {
    var seen = new IntersectionObserver(function (entries) {
      entries.forEach(function (e) {
        if (e.isIntersecting) { seen.unobserve(e.target); start(e.target); }
      });
    }, { rootMargin: "200px" });
    canvases.forEach(function (c) { seen.observe(c); });
  } else {
    canvases.forEach(start);
  }
  document.body.setAttribute("data-ready", "1");
})();
