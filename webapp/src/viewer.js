// The 3D view: the world (Z up, metres) from the server's GLB, seen first through the
// source camera with its exact intrinsics; orbit / pan / zoom; picking, dragging objects
// on the ground, and clicking ground points.
//
// Events (dispatched on the Viewer, an EventTarget):
//   'pick'  {name|null}          a click on an object (or on nothing)
//   'drop'  {name, dx, dy}       an object dragged by (dx, dy) metres on the ground
//   'place' {x, y}               a click on the ground in placing mode
//   'view'  {source: bool}       the view left or returned to the source camera

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

const DRAG_THRESHOLD_PX = 4;
const SKY = 0xb8cde0;
const SELECT_COLOR = 0xffd400;
const Z_UP = new THREE.Vector3(0, 0, 1);

export class Viewer extends EventTarget {
  constructor(viewport, canvas) {
    super();
    this.viewport = viewport;
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, alpha: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.outputColorSpace = THREE.SRGBColorSpace;
    this.scene = new THREE.Scene();
    this.world = new THREE.Group(); // world frame: Z up, metres
    this.scene.add(this.world);
    this.scene.add(new THREE.HemisphereLight(0xe4ecf7, 0x5b5346, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(-40, 60, 120);
    this.scene.add(sun);

    this.camera = new THREE.PerspectiveCamera(50, 2, 0.1, 3000);
    this.camera.up.copy(Z_UP); // before the controls read it
    this.camera.position.set(-10, 0, 5);
    this.camera.lookAt(20, 0, 0);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.enableDamping = false;
    this.controls.zoomToCursor = true;
    this.controls.screenSpacePanning = false; // pan along the ground
    this.controls.maxPolarAngle = Math.PI / 2 - 0.02; // stay above the ground
    // 'change' (not 'start'): a click without a drag keeps the source view
    this.controls.addEventListener('change', () => {
      this._leaveSourceView();
      this.requestRender();
    });

    this.sourceCamera = null; // camera JSON of the world
    this.inSourceView = false;
    this.backdrop = true;
    this.nodes = new Map(); // object name -> Object3D (world frame)
    this.ground = null;
    this.selected = null;
    this.selectionBox = null;
    this.placing = false;
    this.raycaster = new THREE.Raycaster();
    this.loader = new GLTFLoader();
    this.renderCount = 0;
    this._renderQueued = false;
    this._gesture = null;

    canvas.addEventListener('pointerdown', (e) => this._onPointerDown(e), { capture: true });
    canvas.addEventListener('pointermove', (e) => this._onPointerMove(e));
    canvas.addEventListener('pointerup', (e) => this._onPointerUp(e));
    canvas.addEventListener('pointercancel', (e) => this._onPointerUp(e, true));
    new ResizeObserver(() => this.resize()).observe(viewport.parentElement);
    this.resize();
  }

  // --- camera ------------------------------------------------------------------------

  /** Use the world's source camera (or null: a default view) and look through it. */
  setSourceCamera(camera) {
    this.sourceCamera = camera;
    this.resize();
    this.sourceView();
  }

  get aspect() {
    return this.sourceCamera ? this.sourceCamera.width / this.sourceCamera.height : 16 / 9;
  }

  /** Put the view back on the source camera: pose and projection exactly as in the photo. */
  sourceView() {
    const cam = this.sourceCamera;
    if (!cam) {
      this.inSourceView = false;
      this.requestRender();
      return;
    }
    const c = this.camera;
    new THREE.Matrix4().fromArray(cam.world_from_glcam).decompose(c.position, c.quaternion, c.scale);
    c.fov = cam.vertical_fov_deg;
    c.aspect = cam.width / cam.height;
    c.near = cam.near_m;
    c.far = cam.far_m;
    c.projectionMatrix.fromArray(cam.projection);
    c.projectionMatrixInverse.copy(c.projectionMatrix).invert();
    c.updateMatrixWorld(true);
    // Orbit about the ground point on the optical axis (or 25 m ahead when it looks up).
    const forward = new THREE.Vector3(0, 0, -1).applyQuaternion(c.quaternion);
    let distance = 25;
    if (forward.z < -1e-3) distance = Math.min(Math.max(-c.position.z / forward.z, 5), 80);
    this.controls.target.copy(c.position).addScaledVector(forward, distance);
    // No controls.update() here: it would re-aim the camera with lookAt and drop its roll.
    this.inSourceView = true;
    this._applyBackdrop();
    this.dispatchEvent(new CustomEvent('view', { detail: { source: true } }));
    this.requestRender();
  }

  _leaveSourceView() {
    if (!this.inSourceView) return;
    this.inSourceView = false;
    this._applyBackdrop();
    this.dispatchEvent(new CustomEvent('view', { detail: { source: false } }));
  }

  setBackdrop(url, visible) {
    const img = this.viewport.querySelector('#backdrop');
    if (url && img.getAttribute('src') !== url) img.src = url;
    this.backdropAvailable = Boolean(url);
    this.backdrop = visible;
    this._applyBackdrop();
  }

  setOverlayOpacity(value) {
    this.overlayOpacity = value;
    this._applyBackdrop();
  }

  _applyBackdrop() {
    const img = this.viewport.querySelector('#backdrop');
    const show = this.backdropAvailable && this.backdrop && this.inSourceView;
    img.hidden = !show;
    this.scene.background = show ? null : new THREE.Color(SKY);
    this.canvas.style.opacity = show ? String(this.overlayOpacity ?? 0.65) : '1';
    this.requestRender();
  }

  resize() {
    const area = this.viewport.parentElement; // #view-area: the space the view may fill
    const availW = Math.max(area.clientWidth - 2, 100);
    const availH = Math.max(area.clientHeight - 2, 60);
    let w = availW;
    let h = w / this.aspect;
    if (h > availH) {
      h = availH;
      w = h * this.aspect;
    }
    w = Math.floor(w);
    h = Math.floor(h);
    this.viewport.style.width = `${w}px`;
    this.viewport.style.height = `${h}px`;
    this.renderer.setSize(w, h, false);
    if (!this.sourceCamera) {
      this.camera.aspect = w / h;
      this.camera.updateProjectionMatrix();
    }
    this.requestRender();
  }

  // --- scene -------------------------------------------------------------------------

  /** Replace the scene by a GLB (ArrayBuffer). Resolves when it is shown. */
  loadScene(buffer) {
    return new Promise((resolve, reject) => {
      this.loader.parse(
        buffer,
        '',
        (gltf) => {
          this._clearScene();
          const root = gltf.scene;
          root.rotation.x = Math.PI / 2; // glTF Y up -> world Z up
          root.updateMatrixWorld(true);
          for (const node of [...root.children]) {
            this.world.attach(node); // keeps its world transform; node.position is now a world offset
            node.traverse((o) => {
              o.userData.objectName = node.name;
              if (o.isMesh) {
                o.material = new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide });
              }
            });
            if (node.name === 'ground') this.ground = node;
            else this.nodes.set(node.name, node);
          }
          this.world.updateMatrixWorld(true);
          this.select(this.selected);
          this.requestRender();
          resolve();
        },
        (error) => reject(error),
      );
    });
  }

  _clearScene() {
    for (const node of [...this.world.children]) {
      this.world.remove(node);
      node.traverse((o) => {
        if (o.isMesh) {
          o.geometry.dispose();
          o.material.dispose();
        }
      });
    }
    this.nodes.clear();
    this.ground = null;
  }

  select(name) {
    this.selected = name || null;
    if (this.selectionBox) {
      this.scene.remove(this.selectionBox);
      this.selectionBox.geometry.dispose();
      this.selectionBox = null;
    }
    const node = name ? this.nodes.get(name) : null;
    if (node) {
      this.selectionBox = new THREE.BoxHelper(node, SELECT_COLOR);
      this.selectionBox.material.depthTest = false;
      this.selectionBox.renderOrder = 10;
      this.scene.add(this.selectionBox);
    }
    this.requestRender();
  }

  /** Show an object displaced by (dx, dy) metres (0, 0 puts it back where the server has it). */
  setOffset(name, dx, dy) {
    const node = this.nodes.get(name);
    if (!node) return;
    node.position.set(dx, dy, 0);
    node.updateMatrixWorld(true);
    if (this.selectionBox && this.selected === name) this.selectionBox.update();
    this.requestRender();
  }

  setPlacing(on) {
    this.placing = on;
    this.canvas.style.cursor = on ? 'crosshair' : '';
  }

  // --- rendering ---------------------------------------------------------------------

  requestRender() {
    if (this._renderQueued) return;
    this._renderQueued = true;
    requestAnimationFrame(() => {
      this._renderQueued = false;
      this.renderer.render(this.scene, this.camera);
      this.renderCount += 1;
    });
  }

  // --- picking -----------------------------------------------------------------------

  _ray(clientX, clientY) {
    const rect = this.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(
      ((clientX - rect.left) / rect.width) * 2 - 1,
      -((clientY - rect.top) / rect.height) * 2 + 1,
    );
    this.raycaster.setFromCamera(ndc, this.camera);
    return this.raycaster;
  }

  /** Name of the object under a client point, or null. */
  pick(clientX, clientY) {
    const hits = this._ray(clientX, clientY).intersectObjects([...this.nodes.values()], true);
    return hits.length ? hits[0].object.userData.objectName : null;
  }

  /** Ground point (x, y) under a client point, on the plane z = height; null above the horizon. */
  groundPoint(clientX, clientY, height = 0) {
    const plane = new THREE.Plane(Z_UP, -height);
    const hit = new THREE.Vector3();
    return this._ray(clientX, clientY).ray.intersectPlane(plane, hit) ? hit : null;
  }

  /** A surface point under a client point: the ground mesh if hit, else the plane z = 0. */
  surfacePoint(clientX, clientY) {
    if (this.ground) {
      const hits = this._ray(clientX, clientY).intersectObject(this.ground, true);
      if (hits.length) return hits[0].point;
    }
    return this.groundPoint(clientX, clientY, 0);
  }

  _onPointerDown(e) {
    if (e.button !== 0) return;
    const name = this.placing ? null : this.pick(e.clientX, e.clientY);
    this._gesture = { x: e.clientX, y: e.clientY, name, moved: false, start: null, id: e.pointerId };
    if (name) {
      // An object under the pointer: this gesture drags it; the orbit controls sit it out.
      this.controls.enabled = false;
      this.canvas.setPointerCapture(e.pointerId);
      this._gesture.height = this.heightOf ? this.heightOf(name) : 0;
      this._gesture.start = this.groundPoint(e.clientX, e.clientY, this._gesture.height);
      this.canvas.style.cursor = 'grabbing';
    }
  }

  _onPointerMove(e) {
    const g = this._gesture;
    if (!g || g.id !== e.pointerId) return;
    if (!g.moved && Math.hypot(e.clientX - g.x, e.clientY - g.y) > DRAG_THRESHOLD_PX) g.moved = true;
    if (g.name && g.moved && g.start) {
      const p = this.groundPoint(e.clientX, e.clientY, g.height);
      if (p) {
        g.dx = p.x - g.start.x;
        g.dy = p.y - g.start.y;
        this.setOffset(g.name, g.dx, g.dy);
      }
    }
  }

  _onPointerUp(e, cancelled = false) {
    const g = this._gesture;
    if (!g || g.id !== e.pointerId) return;
    this._gesture = null;
    if (g.name) {
      this.controls.enabled = true;
      this.canvas.style.cursor = this.placing ? 'crosshair' : '';
      if (this.canvas.hasPointerCapture(e.pointerId)) this.canvas.releasePointerCapture(e.pointerId);
      if (cancelled) {
        this.setOffset(g.name, 0, 0);
      } else if (g.moved && g.dx !== undefined) {
        this.dispatchEvent(new CustomEvent('drop', { detail: { name: g.name, dx: g.dx, dy: g.dy } }));
      } else {
        this.dispatchEvent(new CustomEvent('pick', { detail: { name: g.name } }));
      }
      return;
    }
    if (g.moved || cancelled) return; // an orbit
    if (this.placing) {
      const p = this.surfacePoint(e.clientX, e.clientY);
      if (p) this.dispatchEvent(new CustomEvent('place', { detail: { x: p.x, y: p.y } }));
    } else {
      this.dispatchEvent(new CustomEvent('pick', { detail: { name: null } }));
    }
  }

  // --- geometry helpers (also used by the end-to-end test) -----------------------------

  /** Client coordinates of a world point. */
  worldToClient(x, y, z) {
    const rect = this.canvas.getBoundingClientRect();
    const p = new THREE.Vector3(x, y, z).project(this.camera);
    return { x: rect.left + ((p.x + 1) / 2) * rect.width, y: rect.top + ((1 - p.y) / 2) * rect.height };
  }

  /** OpenCV pixel coordinates (u, v) in the source photo of a world point, through the current camera. */
  worldToImage(x, y, z) {
    const cam = this.sourceCamera;
    const p = new THREE.Vector3(x, y, z).project(this.camera);
    return { u: ((p.x + 1) / 2) * cam.width - 0.5, v: ((1 - p.y) / 2) * cam.height - 0.5 };
  }

  /** A client point where a click picks the object (its bounding-box centre if that hits it). */
  clientPointOf(name) {
    const node = this.nodes.get(name);
    if (!node) return null;
    const box = new THREE.Box3().setFromObject(node);
    const corners = [];
    for (const x of [box.min.x, box.max.x])
      for (const y of [box.min.y, box.max.y])
        for (const z of [box.min.z, box.max.z]) corners.push(this.worldToClient(x, y, z));
    const xs = corners.map((c) => c.x);
    const ys = corners.map((c) => c.y);
    const [x0, x1, y0, y1] = [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
    const rect = this.canvas.getBoundingClientRect();
    const n = 9;
    const candidates = [];
    for (let i = 0; i < n; i += 1)
      for (let j = 0; j < n; j += 1) {
        const cx = x0 + ((i + 0.5) / n) * (x1 - x0);
        const cy = y0 + ((j + 0.5) / n) * (y1 - y0);
        if (cx < rect.left || cx > rect.right || cy < rect.top || cy > rect.bottom) continue;
        candidates.push({ x: cx, y: cy, d: Math.hypot(i - (n - 1) / 2, j - (n - 1) / 2) });
      }
    candidates.sort((a, b) => a.d - b.d);
    for (const c of candidates) if (this.pick(c.x, c.y) === name) return { x: c.x, y: c.y };
    return null;
  }
}
