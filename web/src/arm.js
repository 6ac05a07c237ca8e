// One arm drawn as its collision capsules: a group per link, placed with the link's world pose from each frame,
// its capsules coloured by the option of the agent of the joint that moves the link. Where the robot's URDF has
// visual elements (hello.robot.visuals) the first arm shows them too, and its capsules turn translucent over them.
import * as THREE from 'three';
import { OPTION_COLORS } from './colors.js';
import { shadedMaterial } from './materials.js';

const Y_AXIS = new THREE.Vector3(0, 1, 0);

export class ArmView {
  // robot: hello.robot; neutral: [r, g, b]; opacity: 1 or translucent (second arm).
  constructor(robot, { neutral, opacity = 1 }) {
    this.group = new THREE.Group();
    this.materials = { neutral: shadedMaterial(neutral, { opacity }) };
    for (const [name, rgb] of Object.entries(OPTION_COLORS)) this.materials[name] = shadedMaterial(rgb, { opacity });
    this.links = robot.links.map(() => {
      const g = new THREE.Group();
      g.visible = false;  // until the first frame places it
      this.group.add(g);
      return { group: g, meshes: [], material: 'neutral' };
    });
    // a translucent arm is drawn a little fatter: side by side, it shares the first arm's place, and a shell around
    // it shows where the two differ instead of flickering where they coincide
    const inflate = opacity < 1 ? 0.004 : 0;
    const visuals = opacity === 1 ? (robot.visuals || []) : [];
    if (visuals.length > 0) {
      this.visualMaterial = shadedMaterial(VISUAL_COLOR, { opacity: 1 });
      for (const v of visuals) this.addVisual(v);
      // the capsules stay, translucent, to carry the agents' colours
      for (const m of Object.values(this.materials)) { m.transparent = true; m.opacity = 0.45; m.depthWrite = false; }
    }
    for (const c of robot.capsules) {
      const link = this.links[c.link];
      if (!link) continue;
      const mesh = capsuleMesh({ ...c, radius: c.radius + inflate }, this.materials.neutral);
      if (opacity < 1) mesh.renderOrder = 1;
      link.group.add(mesh);
      link.meshes.push(mesh);
    }
    this.jointLinks = robot.joint_links || [];
  }

  // places every link at its world pose [x, y, z, qw, qx, qy, qz].
  setPose(poses) {
    const n = Math.min(poses.length, this.links.length);
    for (let k = 0; k < n; ++k) {
      const p = poses[k];
      const g = this.links[k].group;
      g.position.set(p[0], p[1], p[2]);
      g.quaternion.set(p[4], p[5], p[6], p[3]).normalize();
      g.visible = true;
    }
  }

  // colours link joint_links[i] by joints[i].option (an index into optionNames; -1 idle); joints null: all neutral.
  setOptions(joints, optionNames) {
    this.jointLinks.forEach((k, i) => {
      const j = joints ? joints[i] : null;
      const name = j && j.option >= 0 ? optionNames[j.option] : null;
      this.setLinkMaterial(k, name && this.materials[name] ? name : 'neutral');
    });
  }

  setLinkMaterial(k, key) {
    const link = this.links[k];
    if (!link || link.material === key) return;
    link.material = key;
    for (const m of link.meshes) m.material = this.materials[key];
  }

  // one visual element in its link's frame: a primitive at its pose X, or a mesh fetched from the server (a mesh
  // that cannot be fetched, e.g. in a replay, is left out)
  addVisual(v) {
    const link = this.links[v.link];
    if (!link) return;
    let geometry = null;
    if (v.kind === 'box') geometry = new THREE.BoxGeometry(...v.size);
    else if (v.kind === 'sphere') geometry = new THREE.SphereGeometry(v.radius, 20, 14);
    else if (v.kind === 'cylinder') {
      geometry = new THREE.CylinderGeometry(v.radius, v.radius, v.length, 24);
      geometry.rotateX(Math.PI / 2);  // three.js cylinders run along y, URDF ones along z
    }
    const place = (g) => {
      const mesh = new THREE.Mesh(g, this.visualMaterial);
      const X = v.X || [0, 0, 0, 1, 0, 0, 0];
      mesh.position.set(X[0], X[1], X[2]);
      mesh.quaternion.set(X[4], X[5], X[6], X[3]).normalize();
      link.group.add(mesh);
    };
    if (geometry) { place(geometry); return; }
    if (v.kind === 'mesh' && typeof v.url === 'string') {
      fetch(v.url).then((r) => (r.ok ? r.arrayBuffer() : Promise.reject(new Error(`${r.status}`))))
        .then((buffer) => place(meshGeometry(buffer)))
        .catch((e) => console.warn(`visual mesh ${v.url} left out: ${e.message}`));
    }
  }

  dispose() {
    this.group.traverse((o) => { if (o.geometry) o.geometry.dispose(); });
    for (const m of Object.values(this.materials)) m.dispose();
    if (this.visualMaterial) this.visualMaterial.dispose();
  }
}

const VISUAL_COLOR = [178, 184, 190];

// a mesh file of the server: uint32 V, uint32 T, V x 3 float32 positions, T x 3 uint32 indices (little-endian)
function meshGeometry(buffer) {
  const head = new DataView(buffer, 0, 8);
  const nv = head.getUint32(0, true), nt = head.getUint32(4, true);
  if (buffer.byteLength !== 8 + 12 * nv + 12 * nt) throw new Error(`malformed mesh of ${buffer.byteLength} bytes`);
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(buffer, 8, 3 * nv), 3));
  geometry.setIndex(new THREE.BufferAttribute(new Uint32Array(buffer, 8 + 12 * nv, 3 * nt), 1));
  geometry.computeVertexNormals();
  return geometry;
}

// a capsule between link-frame points a and b.
function capsuleMesh({ a, b, radius }, material) {
  const pa = new THREE.Vector3(...a), pb = new THREE.Vector3(...b);
  const axis = pb.clone().sub(pa);
  const length = axis.length();
  const geometry = new THREE.CapsuleGeometry(radius, length, 6, 20);
  const mesh = new THREE.Mesh(geometry, material);
  mesh.position.copy(pa).add(pb).multiplyScalar(0.5);
  if (length > 1e-9) mesh.quaternion.setFromUnitVectors(Y_AXIS, axis.normalize());
  return mesh;
}
