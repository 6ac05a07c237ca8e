// The 3D view: z-up world with a floor grid, the arms, obstacles, target, end effectors and witness lines of the
// latest frame; picking, projection and pixel counting for the drag controller and the test hook.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { ArmView } from './arm.js';
import {
  ARM_COLOR, SECOND_ARM_COLOR, OBSTACLE_COLOR, SELECTED_COLOR, TARGET_COLOR, EE_COLORS, WITNESS_COLORS, BACKGROUND,
} from './colors.js';
import { shadedMaterial, linearColor, HEAD_LIGHT_INTENSITY } from './materials.js';

const TARGET_RADIUS = 0.025;
const TARGET_PICK_RADIUS = 0.05;  // the target is grabbed within this radius: it may be moving
const EE_RADIUS = 0.012;
const MAX_WITNESSES = 64;
const MAX_LABELS = 48;

// an obstacle's mesh geometry in its own frame: a sphere (size [r]), a cylinder along z (size [r, half length];
// three.js builds cylinders along y) or a box (size: half sides).
function obstacleGeometry(o) {
  if (o.shape === 'sphere') return new THREE.SphereGeometry(o.size[0], 28, 18);
  if (o.shape === 'cylinder') {
    return new THREE.CylinderGeometry(o.size[0], o.size[0], 2 * o.size[1], 32).rotateX(Math.PI / 2);
  }
  return new THREE.BoxGeometry(2 * o.size[0], 2 * o.size[1], 2 * o.size[2]);
}

// true when WebGL runs on a software rasteriser (no GPU)
function softwareRenderer() {
  try {
    const gl = document.createElement('canvas').getContext('webgl');
    if (!gl) return true;
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    const name = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
    gl.getExtension('WEBGL_lose_context')?.loseContext();
    return /swiftshader|llvmpipe|software/i.test(String(name));
  } catch (e) {
    return true;
  }
}

export class SceneView {
  constructor(canvas, labelLayer) {
    this.canvas = canvas;
    this.labelLayer = labelLayer;
    // multisampling costs a software renderer (SwiftShader, llvmpipe) most of its frame time: only on a GPU
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: !softwareRenderer(),
      preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.setClearColor(linearColor(BACKGROUND));

    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.01, 50);
    this.camera.up.set(0, 0, 1);
    this.camera.position.set(1.5, -1.2, 1.0);

    this.controls = new OrbitControls(this.camera, canvas);
    // left button drags objects (drag.js); right orbits, middle pans, the wheel zooms
    this.controls.mouseButtons = { LEFT: -1, MIDDLE: THREE.MOUSE.PAN, RIGHT: THREE.MOUSE.ROTATE };
    this.controls.enableDamping = false;
    this.controls.addEventListener('change', () => { this.viewDirty = true; });
    this.controls.minDistance = 0.2;
    this.controls.maxDistance = 12;
    canvas.addEventListener('contextmenu', (e) => e.preventDefault());

    this.headLight = new THREE.DirectionalLight(0xffffff, HEAD_LIGHT_INTENSITY);
    this.scene.add(this.headLight, this.headLight.target);

    const grid = new THREE.GridHelper(4, 40, 0x9aa3ad, 0xc9d0d8);
    grid.rotation.x = Math.PI / 2;  // GridHelper lies in x-z; the floor is x-y
    this.scene.add(grid);
    this.scene.add(new THREE.AxesHelper(0.15));

    this.workspace = new THREE.Box3Helper(new THREE.Box3(), 0xa8b4c0);
    this.workspace.visible = false;
    this.scene.add(this.workspace);

    this.armGroup = new THREE.Group();
    this.scene.add(this.armGroup);
    this.arms = [];

    this.target = new THREE.Mesh(new THREE.SphereGeometry(TARGET_RADIUS, 24, 16), shadedMaterial(TARGET_COLOR));
    this.target.visible = false;
    this.targetPick = new THREE.Mesh(new THREE.SphereGeometry(TARGET_PICK_RADIUS, 12, 8),
      new THREE.MeshBasicMaterial({ visible: false }));
    this.target.add(this.targetPick);
    this.targetHalo = new THREE.Mesh(new THREE.SphereGeometry(TARGET_RADIUS * 1.6, 24, 16),
      new THREE.MeshBasicMaterial({ color: linearColor(TARGET_COLOR), transparent: true, opacity: 0.25, depthWrite: false }));
    this.target.add(this.targetHalo);
    // the end effector tracks the target inside the last link's capsule: a faint copy drawn on top keeps it in sight
    const ghost = new THREE.Mesh(this.target.geometry, new THREE.MeshBasicMaterial({
      color: linearColor(TARGET_COLOR), transparent: true, opacity: 0.45, depthTest: false, depthWrite: false }));
    ghost.renderOrder = 2;
    this.target.add(ghost);
    this.scene.add(this.target);

    this.eeMarkers = EE_COLORS.map((rgb) => {
      const m = new THREE.Mesh(new THREE.SphereGeometry(EE_RADIUS, 16, 12),
        new THREE.MeshBasicMaterial({ color: linearColor(rgb), depthTest: false, transparent: true }));
      m.renderOrder = 3;
      m.visible = false;
      this.scene.add(m);
      return m;
    });

    this.witness = WITNESS_COLORS.map((rgb) => {
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(MAX_WITNESSES * 6), 3));
      geometry.setDrawRange(0, 0);
      const lines = new THREE.LineSegments(geometry,
        new THREE.LineBasicMaterial({ color: linearColor(rgb), depthTest: false, transparent: true }));
      lines.renderOrder = 2;
      lines.frustumCulled = false;
      this.scene.add(lines);
      return lines;
    });
    this.labels = [];

    this.obstacleMaterial = shadedMaterial(OBSTACLE_COLOR);
    this.heldObstacleMaterial = shadedMaterial(OBSTACLE_COLOR.map((c) => Math.min(255, c + 30)));
    this.selectedMaterial = shadedMaterial(SELECTED_COLOR);
    this.obstacles = new Map();  // id → {mesh, key}
    this.obstacleGroup = new THREE.Group();
    this.scene.add(this.obstacleGroup);

    this.hello = null;
    this.frame = null;
    this.frameDirty = false;
    this.viewDirty = true;      // the camera moved or the canvas was resized: draw again
    this.draws = 0;             // renders so far (the page draws only when something changed)
    this.continuous = false;    // draw at every animation frame (to measure what the browser can draw)
    this.selected = null;       // id of the selected obstacle
    this.override = null;       // {kind: 'target'|'obstacle', id, p}: what a drag shows before the server confirms
    this.cameraPlaced = false;
    this.raycaster = new THREE.Raycaster();

    this.resize();
    new ResizeObserver(() => this.resize()).observe(canvas.parentElement);
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.canvas.parentElement;
    if (w === 0 || h === 0) return;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.viewDirty = true;
  }

  setHello(hello) {
    const first = this.hello === null;
    const robotChanged = first || JSON.stringify(hello.robot) !== JSON.stringify(this.hello.robot);
    const armsChanged = robotChanged || hello.arms.length !== this.arms.length;
    this.hello = hello;
    if (armsChanged) {
      for (const a of this.arms) { this.armGroup.remove(a.group); a.dispose(); }
      this.arms = hello.arms.map((_, i) => new ArmView(hello.robot, i === 0
        ? { neutral: ARM_COLOR, opacity: 1 } : { neutral: SECOND_ARM_COLOR, opacity: 0.35 }));
      for (const a of this.arms) this.armGroup.add(a.group);
    }
    const ws = hello.workspace;
    if (ws) {
      this.workspace.box.min.set(...ws.min);
      this.workspace.box.max.set(...ws.max);
      this.workspace.visible = true;
    }
    if (!this.cameraPlaced && ws) {
      // look at the centre of the workspace from the front right (the arm reaches along +x; its right is −y)
      const c = new THREE.Vector3(...ws.min).add(new THREE.Vector3(...ws.max)).multiplyScalar(0.5);
      const size = new THREE.Vector3(...ws.max).sub(new THREE.Vector3(...ws.min)).length();
      const dist = Math.max(1.0, 1.7 * size);
      this.controls.target.copy(c);
      this.camera.position.copy(c).add(new THREE.Vector3(0.75, -0.55, 0.38).normalize().multiplyScalar(dist));
      this.controls.update();
      this.cameraPlaced = true;
    }
    this.frameDirty = true;
  }

  setFrame(frame) {
    this.frame = frame;
    this.frameDirty = true;
  }

  select(id) {
    this.selected = id;
    this.frameDirty = true;
  }

  setOverride(override) {
    this.override = override;
    this.frameDirty = true;
  }

  // brings the scene to the latest frame (once per animation frame).
  update() {
    const f = this.frame, hello = this.hello;
    if (f && hello && this.frameDirty) {
      this.frameDirty = false;
      const arms = f.arms || [];
      this.arms.forEach((arm, i) => {
        const a = arms[i];
        arm.group.visible = !!a;
        if (!a) return;
        arm.setPose(a.links);
        arm.setOptions(a.joints, hello.options);
      });
      this.eeMarkers.forEach((m, i) => {
        const a = arms[i];
        m.visible = !!(a && a.ee);
        if (m.visible) m.position.set(...a.ee);
      });

      const ov = this.override;
      const tp = ov && ov.kind === 'target' ? ov.p : f.target.p;
      this.target.position.set(...tp);
      this.target.visible = true;
      this.targetHalo.visible = !!(f.target.held || (ov && ov.kind === 'target'));

      this.updateObstacles(f.obstacles || []);
      this.updateWitnesses(arms);
    }
    this.placeLabels();
  }

  updateObstacles(list) {
    const seen = new Set();
    for (const o of list) {
      seen.add(o.id);
      const key = o.shape + ':' + o.size.join(',');
      let entry = this.obstacles.get(o.id);
      if (!entry || entry.key !== key) {
        if (entry) { this.obstacleGroup.remove(entry.mesh); entry.mesh.geometry.dispose(); }
        const geometry = obstacleGeometry(o);
        entry = { mesh: new THREE.Mesh(geometry, this.obstacleMaterial), key };
        entry.mesh.userData.obstacleId = o.id;
        this.obstacles.set(o.id, entry);
        this.obstacleGroup.add(entry.mesh);
      }
      const ov = this.override;
      const p = ov && ov.kind === 'obstacle' && ov.id === o.id ? ov.p : o.p;
      entry.mesh.position.set(...p);
      if (o.q) entry.mesh.quaternion.set(o.q[1], o.q[2], o.q[3], o.q[0]).normalize();
      entry.mesh.material = this.selected === o.id ? this.selectedMaterial
        : o.held ? this.heldObstacleMaterial : this.obstacleMaterial;
    }
    for (const [id, entry] of this.obstacles) {
      if (seen.has(id)) continue;
      this.obstacleGroup.remove(entry.mesh);
      entry.mesh.geometry.dispose();
      this.obstacles.delete(id);
    }
  }

  updateWitnesses(arms) {
    this.labelData = [];
    this.witness.forEach((lines, i) => {
      const list = (arms[i] && arms[i].witness) || [];
      const attr = lines.geometry.getAttribute('position');
      const n = Math.min(list.length, MAX_WITNESSES);
      for (let k = 0; k < n; ++k) {
        const w = list[k];
        attr.array.set(w.a, 6 * k);
        attr.array.set(w.b, 6 * k + 3);
        this.labelData.push({ arm: i, p: w.a.map((x, j) => 0.5 * (x + w.b[j])), d: w.d });
      }
      attr.needsUpdate = true;
      lines.geometry.setDrawRange(0, 2 * n);
      lines.visible = n > 0;
    });
  }

  // html labels with the witness distances, re-projected every animation frame (the camera may move).
  placeLabels() {
    const data = (this.labelData || []).slice(0, MAX_LABELS);
    while (this.labels.length < data.length) {
      const el = document.createElement('div');
      el.className = 'witness-label';
      this.labelLayer.appendChild(el);
      this.labels.push(el);
    }
    const rect = this.canvas.getBoundingClientRect();
    const v = new THREE.Vector3();
    this.labels.forEach((el, k) => {
      const d = data[k];
      if (!d) { el.style.display = 'none'; return; }
      v.set(...d.p).project(this.camera);
      if (v.z > 1 || v.z < -1) { el.style.display = 'none'; return; }
      el.style.display = '';
      el.style.left = `${((v.x + 1) / 2) * rect.width}px`;
      el.style.top = `${((1 - v.y) / 2) * rect.height}px`;
      el.className = d.arm === 0 ? 'witness-label' : 'witness-label second';
      const text = `${Math.round(d.d * 1000)} mm`;
      if (el.textContent !== text) el.textContent = text;
    });
  }

  // draws when a frame, the selection, a drag or the camera changed since the last draw; returns whether it drew.
  render() {
    this.controls.update();
    if (!this.frameDirty && !this.viewDirty && !this.continuous) return false;
    this.viewDirty = false;
    this.update();
    this.headLight.position.copy(this.camera.position);
    this.headLight.target.position.copy(this.controls.target);
    this.renderer.render(this.scene, this.camera);
    this.draws += 1;
    return true;
  }

  // the ray under a point of the page (CSS pixels).
  rayAt(clientX, clientY) {
    const rect = this.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - rect.left) / rect.width) * 2 - 1,
      -((clientY - rect.top) / rect.height) * 2 + 1);
    this.camera.updateMatrixWorld();
    this.raycaster.setFromCamera(ndc, this.camera);
    return this.raycaster.ray;
  }

  // what is under a point of the page: {kind: 'target'} or {kind: 'obstacle', id}, with the hit point and the
  // object's centre; null for nothing.
  pick(clientX, clientY) {
    this.rayAt(clientX, clientY);
    const candidates = [...this.obstacleGroup.children];
    if (this.target.visible) candidates.push(this.targetPick);
    const hits = this.raycaster.intersectObjects(candidates, false);
    if (hits.length === 0) return null;
    const hit = hits[0];
    if (hit.object === this.targetPick) {
      return { kind: 'target', point: hit.point.clone(), centre: this.target.position.clone() };
    }
    return { kind: 'obstacle', id: hit.object.userData.obstacleId, point: hit.point.clone(),
      centre: hit.object.position.clone() };
  }

  // the page position (CSS pixels) of a world point.
  project(p) {
    this.camera.updateMatrixWorld();
    const v = new THREE.Vector3(p[0], p[1], p[2]).project(this.camera);
    const rect = this.canvas.getBoundingClientRect();
    return { x: rect.left + ((v.x + 1) / 2) * rect.width, y: rect.top + ((1 - v.y) / 2) * rect.height };
  }

  // the obstacles' meshes as drawn, in plain numbers: id, the three.js geometry's type and parameters, its bounding
  // box's size in the mesh's frame, and the mesh's world position and quaternion [x, y, z, w].
  obstacleMeshes() {
    this.scene.updateMatrixWorld();
    return [...this.obstacles].map(([id, { mesh }]) => {
      const g = mesh.geometry;
      if (!g.boundingBox) g.computeBoundingBox();
      return { id, type: g.type, parameters: { ...g.parameters },
        extent: g.boundingBox.getSize(new THREE.Vector3()).toArray(),
        p: mesh.getWorldPosition(new THREE.Vector3()).toArray(),
        q: mesh.getWorldQuaternion(new THREE.Quaternion()).toArray() };
    });
  }

  // canvas pixels whose colour is within tol (per channel) of rgb.
  countPixels(rgb, tol) {
    const gl = this.renderer.getContext();
    const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const px = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    let n = 0;
    for (let i = 0; i < px.length; i += 4) {
      if (Math.abs(px[i] - rgb[0]) <= tol && Math.abs(px[i + 1] - rgb[1]) <= tol && Math.abs(px[i + 2] - rgb[2]) <= tol) ++n;
    }
    return n;
  }
}
