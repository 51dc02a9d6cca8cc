/* mmplan 3D viewer: a small canvas-2D line renderer (no WebGL, no network).
 * Reads the JSON in <script id="mmplan-scene" type="application/json">, draws the robot's
 * links, collision points, end-effector and platform paths and obstacle wireframes with a
 * perspective camera (z up). Drag to orbit, wheel to zoom, double-click to reset the view.
 * Part of mmplan (MIT licence). */
(function () {
  "use strict";

  function decodeFrames(scene) {
    var raw = atob(scene.frames);
    var bytes = new Uint8Array(raw.length);
    for (var i = 0; i < raw.length; i++) bytes[i] = raw.charCodeAt(i);
    var values = scene.dtype === "int16" ? new Int16Array(bytes.buffer) : new Float32Array(bytes.buffer);
    var expected = scene.t.length * scene.nPoints * 3;
    if (values.length !== expected) {
      throw new Error("mmplan viewer: frame data has " + values.length + " values, expected " + expected);
    }
    var out = new Float32Array(values.length);
    for (var j = 0; j < values.length; j++) out[j] = values[j] * scene.scale;
    return out;
  }

  function Viewer(root, scene) {
    this.root = root;
    this.scene = scene;
    this.frames = decodeFrames(scene);
    this.canvas = root.querySelector("canvas");
    this.ctx = this.canvas.getContext("2d");
    this.slider = root.querySelector("input[type=range]");
    this.button = root.querySelector("button.play");
    this.label = root.querySelector(".time");
    this.speed = root.querySelector("select.speed");
    this.frame = 0;
    this.playing = false;
    this.playTime = scene.t[0];
    this.lastStamp = null;
    this.drawn = 0;
    this.slider.max = String(scene.t.length - 1);
    this.bounds();
    this.resetView();
    this.bind();
    this.resize();
  }

  Viewer.prototype.bounds = function () {
    var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    function take(arr) {
      for (var i = 0; i + 2 < arr.length; i += 3) {
        for (var k = 0; k < 3; k++) {
          var v = arr[i + k];
          if (isFinite(v)) { if (v < lo[k]) lo[k] = v; if (v > hi[k]) hi[k] = v; }
        }
      }
    }
    take(this.scene.eePath);
    take(this.scene.basePath);
    this.scene.obstacles.forEach(function (o) { o.lines.forEach(take); });
    lo[2] = Math.min(lo[2], 0);
    this.center = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
    var d = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    this.extent = isFinite(d) && d > 0 ? d : 1;
    this.lo = lo; this.hi = hi;
  };

  Viewer.prototype.resetView = function () {
    this.azimuth = -2.2;
    this.elevation = 0.55;
    this.distance = 1.2 * this.extent;
  };

  Viewer.prototype.bind = function () {
    var self = this, dragging = null;
    this.canvas.addEventListener("mousedown", function (e) { dragging = [e.clientX, e.clientY]; });
    window.addEventListener("mouseup", function () { dragging = null; });
    window.addEventListener("mousemove", function (e) {
      if (!dragging) return;
      self.azimuth -= (e.clientX - dragging[0]) * 0.01;
      self.elevation = Math.max(-1.5, Math.min(1.5, self.elevation + (e.clientY - dragging[1]) * 0.01));
      dragging = [e.clientX, e.clientY];
      self.draw();
    });
    this.canvas.addEventListener("wheel", function (e) {
      e.preventDefault();
      self.distance *= Math.exp(e.deltaY * 0.001);
      self.draw();
    }, { passive: false });
    this.canvas.addEventListener("dblclick", function () { self.resetView(); self.draw(); });
    this.slider.addEventListener("input", function () {
      self.setFrame(parseInt(self.slider.value, 10));
      self.playTime = self.scene.t[self.frame];
    });
    this.button.addEventListener("click", function () { self.toggle(); });
    window.addEventListener("resize", function () { self.resize(); });
  };

  Viewer.prototype.resize = function () {
    var ratio = window.devicePixelRatio || 1;
    var width = Math.max(320, this.root.clientWidth);
    var height = Math.round(Math.min(560, Math.max(300, width * 0.6)));
    this.canvas.style.width = width + "px";
    this.canvas.style.height = height + "px";
    this.canvas.width = Math.round(width * ratio);
    this.canvas.height = Math.round(height * ratio);
    this.ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    this.width = width; this.height = height;
    this.draw();
  };

  Viewer.prototype.toggle = function () {
    var t = this.scene.t;
    this.playing = !this.playing;
    this.button.textContent = this.playing ? "Pause" : "Play";
    if (this.playing) {
      if (this.frame >= t.length - 1) this.playTime = t[0];
      this.lastStamp = null;
      this.tick();
    }
  };

  // Timer-driven (about 60 Hz) rather than requestAnimationFrame, so that playback also
  // advances where no frames are composited (headless browsers, virtual time).
  Viewer.prototype.tick = function () {
    if (!this.playing) return;
    var t = this.scene.t, stamp = performance.now();
    if (this.lastStamp !== null) {
      this.playTime += (stamp - this.lastStamp) / 1000 * parseFloat(this.speed.value);
    }
    this.lastStamp = stamp;
    var lo = 0, hi = t.length - 1;
    while (lo < hi) { var mid = (lo + hi + 1) >> 1; if (t[mid] <= this.playTime) lo = mid; else hi = mid - 1; }
    this.setFrame(lo);
    if (lo >= t.length - 1) { this.toggle(); return; }
    window.setTimeout(this.tick.bind(this), 16);
  };

  Viewer.prototype.setFrame = function (k) {
    this.frame = Math.max(0, Math.min(this.scene.t.length - 1, k));
    this.slider.value = String(this.frame);
    this.draw();
  };

  Viewer.prototype.project = function (x, y, z) {
    var ca = Math.cos(this.azimuth), sa = Math.sin(this.azimuth);
    var ce = Math.cos(this.elevation), se = Math.sin(this.elevation);
    var rx = x - this.center[0], ry = y - this.center[1], rz = z - this.center[2];
    var right = -sa * rx + ca * ry;
    var up = -se * ca * rx - se * sa * ry + ce * rz;
    var depth = this.distance - (ce * ca * rx + ce * sa * ry + se * rz);
    if (depth < 0.02 * this.extent) return null;
    var f = 0.9 * Math.min(this.width, this.height) * 1.1;
    return [this.width / 2 + f * right / depth, this.height / 2 - f * up / depth];
  };

  Viewer.prototype.polyline = function (arr, start, end, stroke, width) {
    var ctx = this.ctx, open = false;
    ctx.beginPath();
    for (var i = start; i + 2 < end; i += 3) {
      var p = this.project(arr[i], arr[i + 1], arr[i + 2]);
      if (!p) { open = false; continue; }
      if (open) ctx.lineTo(p[0], p[1]); else ctx.moveTo(p[0], p[1]);
      open = true;
    }
    ctx.strokeStyle = stroke;
    ctx.lineWidth = width;
    ctx.stroke();
  };

  Viewer.prototype.grid = function () {
    var step = Math.pow(10, Math.floor(Math.log10(this.extent / 2)));
    var x0 = Math.floor(this.lo[0] / step) * step - step, x1 = Math.ceil(this.hi[0] / step) * step + step;
    var y0 = Math.floor(this.lo[1] / step) * step - step, y1 = Math.ceil(this.hi[1] / step) * step + step;
    for (var x = x0; x <= x1 + 1e-9; x += step) this.polyline([x, y0, 0, x, y1, 0], 0, 6, "#e3e6ea", 1);
    for (var y = y0; y <= y1 + 1e-9; y += step) this.polyline([x0, y, 0, x1, y, 0], 0, 6, "#e3e6ea", 1);
    this.polyline([0, 0, 0, step, 0, 0], 0, 6, "#d62728", 2);
    this.polyline([0, 0, 0, 0, step, 0], 0, 6, "#2ca02c", 2);
    this.polyline([0, 0, 0, 0, 0, step], 0, 6, "#1f77b4", 2);
  };

  Viewer.prototype.draw = function () {
    if (!this.width) return;
    var ctx = this.ctx, scene = this.scene, self = this;
    ctx.fillStyle = "#ffffff";
    ctx.fillRect(0, 0, this.width, this.height);
    this.grid();
    scene.obstacles.forEach(function (o) {
      o.lines.forEach(function (line) { self.polyline(line, 0, line.length, o.color, 1); });
    });
    this.polyline(scene.basePath, 0, scene.basePath.length, "#9aa0a6", 1.5);
    this.polyline(scene.eePath, 0, scene.eePath.length, "#ffbb78", 1.5);
    var n = scene.nPoints, base = this.frame * n * 3, fr = this.frames;
    var ee = base + 3 * scene.eeIndex;
    this.polyline(scene.eePath, 0, Math.min(scene.eePath.length, 3 * (this.frame + 1)), "#ff7f0e", 2);
    scene.links.forEach(function (link) {
      var a = base + 3 * link[0], b = base + 3 * link[1];
      self.polyline([fr[a], fr[a + 1], fr[a + 2], fr[b], fr[b + 1], fr[b + 2]], 0, 6, "#202124", 3.5);
    });
    ctx.fillStyle = "#5f6368";
    for (var i = scene.nBodies + 1; i < n; i++) {
      var p = this.project(fr[base + 3 * i], fr[base + 3 * i + 1], fr[base + 3 * i + 2]);
      if (p) { ctx.beginPath(); ctx.arc(p[0], p[1], 2, 0, 2 * Math.PI); ctx.fill(); }
    }
    var q = this.project(fr[ee], fr[ee + 1], fr[ee + 2]);
    if (q) { ctx.fillStyle = "#d62728"; ctx.beginPath(); ctx.arc(q[0], q[1], 4.5, 0, 2 * Math.PI); ctx.fill(); }
    if (scene.goal) {
      var g = this.project(scene.goal[0], scene.goal[1], scene.goal[2]);
      if (g) {
        ctx.strokeStyle = "#2ca02c"; ctx.lineWidth = 2; ctx.beginPath();
        ctx.moveTo(g[0] - 6, g[1] - 6); ctx.lineTo(g[0] + 6, g[1] + 6);
        ctx.moveTo(g[0] - 6, g[1] + 6); ctx.lineTo(g[0] + 6, g[1] - 6); ctx.stroke();
      }
    }
    var t = scene.t;
    this.label.textContent = "t = " + t[this.frame].toFixed(2) + " s / " + t[t.length - 1].toFixed(2) + " s";
    this.drawn += 1;
    this.canvas.dataset.drawn = String(this.drawn);
    this.canvas.dataset.frame = String(this.frame);
  };

  function start() {
    var root = document.getElementById("mmplan-viewer");
    var data = document.getElementById("mmplan-scene");
    if (!root || !data) return;
    try {
      var viewer = new Viewer(root, JSON.parse(data.textContent));
      root.dataset.frames = String(viewer.scene.t.length);
      window.mmplanViewer = viewer;
    } catch (err) {
      root.querySelector(".message").textContent = "3D view unavailable: " + err.message;
      console.error(err);
    }
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
