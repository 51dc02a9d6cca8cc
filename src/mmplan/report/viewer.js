// mmplan report: the 3D view. Hands the embedded meshcat commands to meshcat's viewer
// (MeshCat.Viewer, the three.js bundle inlined before this script) and adds what a report
// reader needs below it: play/pause, a time slider, the speed, "follow the robot",
// the collision model, and labels (grid scale in metres, obstacles, start, goal) drawn over
// the view. No server, no network: meshcat's own page gets the same commands by websocket.
(function () {
  "use strict";

  function decode(b64) {
    var s = atob(b64), out = new Uint8Array(s.length);
    for (var i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
    return out;
  }

  function webgl() {
    try {
      var c = document.createElement("canvas");
      return !!(window.WebGLRenderingContext && (c.getContext("webgl2") || c.getContext("webgl")));
    } catch (e) {
      return false;
    }
  }

  function View(root, scene) {
    this.root = root;
    this.meta = scene.meta;
    this.pane = root.querySelector(".pane");
    this.button = root.querySelector("button.play");
    this.slider = root.querySelector("input.time");
    this.label = root.querySelector(".clock");
    this.speed = root.querySelector("select.speed");
    this.follow = root.querySelector("input.follow");
    this.points = root.querySelector("input.points");
    this.overlay = root.querySelector(".labels");
    var pane = this.pane;
    var viewer = new MeshCat.Viewer(pane);
    // meshcat sizes its canvas to the window; the report gives it the pane instead
    var fit = MeshCat.Viewer.prototype.set_3d_pane_size;
    viewer.set_3d_pane_size = function (w, h) {
      fit.call(viewer, w === undefined ? pane.clientWidth : w, h === undefined ? pane.clientHeight : h);
    };
    this.viewer = viewer;
    scene.commands.forEach(function (b64) { viewer.handle_command_bytearray(decode(b64)); });
    viewer.set_3d_pane_size();
    this.animator = viewer.animator;
    this.duration = this.meta.duration;
    this.bind();
    this.animator.play();  // make the actions active so that seeking shows them ...
    this.animator.pause();  // ... without playing yet
    this.seek(0);
    this.look(this.follow.checked && this.meta.follow ? "robot" : "scene");
    this.makeLabels();
    var self = this, render = viewer.render.bind(viewer), animate = viewer.animate.bind(viewer);
    viewer.render = function () {
      self.track();
      render();
      self.placeLabels();
    };
    // meshcat animates on animation frames; where none come (a hidden tab, a headless
    // browser on virtual time) a timer keeps playback going
    this.lastFrame = 0;
    viewer.animate = function () {
      self.lastFrame = performance.now();
      animate();
    };
    window.setInterval(function () {
      if (self.animator.playing && performance.now() - self.lastFrame > 150) {
        self.animator.update();
        if (viewer.needs_render) viewer.render();
      }
    }, 50);
    viewer.set_dirty();
  }

  View.prototype.node = function (path) {
    return this.viewer.scene_tree.find(path.split("/")).object;
  };

  View.prototype.bind = function () {
    var self = this, animator = this.animator;
    this.slider.max = String(this.duration);
    this.slider.step = String(Math.max(this.duration / 2000, 0.001));
    var shown = animator.display_progress.bind(animator);
    animator.display_progress = function (time) {  // meshcat reports the time: mirror it
      shown(time);
      self.showTime(time);
    };
    var pause = animator.pause.bind(animator), play = animator.play.bind(animator);
    animator.pause = function () {  // also from meshcat's own panel ("Open Controls")
      pause();
      self.button.textContent = "Play";
    };
    animator.play = function () {
      play();
      self.button.textContent = "Pause";
    };
    this.button.addEventListener("click", function () { self.toggle(); });
    this.slider.addEventListener("input", function () { self.seek(parseFloat(self.slider.value)); });
    this.speed.addEventListener("change", function () {
      animator.mixer.timeScale = parseFloat(self.speed.value);
    });
    this.follow.addEventListener("change", function () {
      self.look(self.follow.checked ? "robot" : "scene");
    });
    this.points.addEventListener("change", function () {
      var visible = self.points.checked;
      self.meta.bodies.forEach(function (body) {
        var node = self.viewer.scene_tree.find(body.split("/"));
        if (node.children.collision) node.children.collision.set_property("visible", visible);
      });
      self.viewer.set_dirty();
    });
    window.addEventListener("resize", function () { self.viewer.set_3d_pane_size(); });
  };

  View.prototype.toggle = function () {
    var animator = this.animator;
    if (animator.playing) {
      animator.pause();
    } else {
      if (animator.time >= this.duration - 1e-6) this.seek(0);
      animator.mixer.timeScale = parseFloat(this.speed.value);
      animator.play();
    }
  };

  View.prototype.seek = function (time) {
    this.animator.seek(time);
    this.animator.display_progress(time);
  };

  View.prototype.showTime = function (time) {
    var m = this.meta, now = m.t0 + time / m.scale, end = m.t0 + this.duration / m.scale;
    this.slider.value = String(time);
    this.label.textContent = m.timed ?
      "t = " + now.toFixed(2) + " s of " + end.toFixed(2) + " s" :
      "s = " + now.toFixed(2) + " of " + end.toFixed(2) + " (path parameter)";
    this.root.dataset.time = String(time);
  };

  // Positions in the plan's frame (z up) are those of meshcat's scene node; three.js's world,
  // in which the camera and its orbit controls work, has y up (meshcat turns the scene).
  View.prototype.world = function (x, y, z) {
    return this.viewer.scene.localToWorld(new MeshCat.THREE.Vector3(x, y, z));
  };

  View.prototype.look = function (name) {
    var view = this.meta.camera[name], t = view.target;
    if (name === "robot" && this.meta.follow) {
      var p = this.node(this.meta.follow).position;
      t = [p.x, p.y, view.target[2]];
    }
    var o = view.offset;
    this.viewer.controls.target.copy(this.world(t[0], t[1], t[2]));
    this.viewer.camera.position.copy(this.world(t[0] + o[0], t[1] + o[1], t[2] + o[2]));
    this.viewer.controls.update();
    this.viewer.set_dirty();
  };

  // "follow the robot": target and camera move with the followed body (the platform), so
  // that the reader's own orbit and zoom are kept
  View.prototype.track = function () {
    if (!this.follow.checked || !this.meta.follow) return;
    var p = this.node(this.meta.follow).position, controls = this.viewer.controls;
    var here = this.world(p.x, p.y, this.meta.camera.robot.target[2]);
    var shift = here.sub(controls.target);
    if (shift.lengthSq() > 0) {
      controls.target.add(shift);
      this.viewer.camera.position.add(shift);
    }
  };

  View.prototype.makeLabels = function () {
    var overlay = this.overlay;
    this.labels = this.meta.labels.map(function (item) {
      var div = document.createElement("div");
      div.className = "label " + item[4];
      div.textContent = item[3];
      overlay.appendChild(div);
      return { div: div, at: [item[0], item[1], item[2]] };
    });
  };

  View.prototype.placeLabels = function () {
    var camera = this.viewer.camera, w = this.pane.clientWidth, h = this.pane.clientHeight;
    var self = this;
    this.labels.forEach(function (label) {
      var v = self.world(label.at[0], label.at[1], label.at[2]).project(camera);
      var inside = v.z < 1 && Math.abs(v.x) <= 1 && Math.abs(v.y) <= 1;
      label.div.style.display = inside ? "block" : "none";
      if (inside) {
        label.div.style.left = ((v.x + 1) / 2 * w).toFixed(1) + "px";
        label.div.style.top = ((1 - v.y) / 2 * h).toFixed(1) + "px";
      }
    });
  };

  function start() {
    var root = document.getElementById("mmplan-viewer");
    var data = document.getElementById("mmplan-scene");
    if (!root || !data) return;
    var message = root.querySelector(".message");
    if (!webgl()) {
      message.textContent = "The 3D view needs WebGL, which this browser does not offer here; " +
        "the figures below show the same plan.";
      root.dataset.ready = "no-webgl";
      return;
    }
    try {
      var view = new View(root, JSON.parse(data.textContent));
      window.mmplanView = view;
      root.dataset.ready = "yes";
    } catch (err) {
      message.textContent = "3D view unavailable: " + err.message;
      root.dataset.ready = "error";
      throw err;
    }
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
