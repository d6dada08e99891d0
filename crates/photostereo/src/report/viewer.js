// photostereo report: interactive 3-D view of the reconstructed surface (three.js).
// Reads the mesh from the JSON block #ps-mesh; reports its state in <html data-viewer=...>.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const root = document.documentElement;
const box = document.getElementById('ps-viewer');

function bytes(b64) {
  const bin = atob(b64);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out.buffer;
}

function buildMesh(data) {
  const geom = new THREE.BufferGeometry();
  geom.setAttribute('position', new THREE.BufferAttribute(new Float32Array(bytes(data.positions)), 3));
  geom.setAttribute('normal', new THREE.BufferAttribute(new Float32Array(bytes(data.normals)), 3));
  if (data.colors) {
    geom.setAttribute('color', new THREE.BufferAttribute(new Uint8Array(bytes(data.colors)), 3, true));
  }
  geom.setIndex(new THREE.BufferAttribute(new Uint32Array(bytes(data.indices)), 1));
  const material = new THREE.MeshStandardMaterial({
    color: data.colors ? 0xffffff : 0xc9c4bb,
    vertexColors: !!data.colors,
    roughness: 0.75,
    metalness: 0.0,
    side: THREE.DoubleSide,
  });
  return new THREE.Mesh(geom, material);
}

// Camera directions (unit vectors from the target toward the camera) and up vectors.
const VIEWS = {
  // Facing the object from slightly above: the rim hides the near inner wall of a hollow.
  home: { dir: [0, Math.sin(0.35), Math.cos(0.35)], up: [0, 1, 0] },
  front: { dir: [0, 0, 1], up: [0, 1, 0] },
  side: { dir: [1, 0, 0], up: [0, 1, 0] },
  top: { dir: [0, 1, 0.02], up: [0, 1, 0] }, // far side up; OrbitControls keeps y up
};

// Bounding box of the vertex positions.
function bounds(pos) {
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < pos.length; i += 3) {
    for (let a = 0; a < 3; a++) {
      lo[a] = Math.min(lo[a], pos[i + a]);
      hi[a] = Math.max(hi[a], pos[i + a]);
    }
  }
  return { lo, hi };
}

// Camera distance at which the box fills the view seen along `dir` with `up`.
function fitDistance(box, center, dir, up, fovDeg, aspect) {
  const back = new THREE.Vector3().fromArray(dir).normalize();
  const upv = new THREE.Vector3().fromArray(up);
  const right = new THREE.Vector3().crossVectors(upv, back).normalize();
  const upo = new THREE.Vector3().crossVectors(back, right);
  const t = Math.tan((fovDeg / 2) * Math.PI / 180);
  let need = 0;
  for (let k = 0; k < 8; k++) {
    const p = new THREE.Vector3(
      k & 1 ? box.hi[0] : box.lo[0], k & 2 ? box.hi[1] : box.lo[1], k & 4 ? box.hi[2] : box.lo[2]
    ).sub(center);
    const front = p.dot(back); // toward the camera: this corner is closer
    need = Math.max(need, front + Math.abs(p.dot(upo)) / t, front + Math.abs(p.dot(right)) / (t * aspect));
  }
  return need * 1.08;
}

function start() {
  const data = JSON.parse(document.getElementById('ps-mesh').textContent);
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(box.clientWidth, box.clientHeight);
  renderer.shadowMap.enabled = true;
  renderer.shadowMap.type = THREE.PCFSoftShadowMap;
  box.appendChild(renderer.domElement);

  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x1b1e24);
  const mesh = buildMesh(data);
  mesh.castShadow = true;
  mesh.receiveShadow = true;
  scene.add(mesh);

  const box3 = bounds(mesh.geometry.attributes.position.array);
  const c = new THREE.Vector3(
    (box3.lo[0] + box3.hi[0]) / 2, (box3.lo[1] + box3.hi[1]) / 2, (box3.lo[2] + box3.hi[2]) / 2
  );
  const size = Math.max(box3.hi[0] - box3.lo[0], box3.hi[1] - box3.lo[1], box3.hi[2] - box3.lo[2], 1e-3);
  const FOV = 30;
  const camera = new THREE.PerspectiveCamera(FOV, box.clientWidth / box.clientHeight, size * 0.01, size * 50);
  scene.add(camera);

  // Soft fill from the sky, and a key light from the upper left of the view at a raking
  // angle that casts shadows: relief reads from its shading, a hollow from the shadow of
  // its rim on the inner wall.
  scene.add(new THREE.HemisphereLight(0xffffff, 0x30343c, 0.55));
  const key = new THREE.DirectionalLight(0xffffff, 2.2);
  key.castShadow = true;
  key.shadow.mapSize.set(2048, 2048);
  const sc = key.shadow.camera;
  sc.left = -size; sc.right = size; sc.top = size; sc.bottom = -size;
  sc.near = size * 0.05; sc.far = size * 6;
  key.shadow.bias = -0.0005;
  key.shadow.normalBias = size * 0.002;
  scene.add(key);
  scene.add(key.target);

  const controls = new OrbitControls(camera, renderer.domElement);
  const placeLight = () => {
    const back = camera.position.clone().sub(controls.target).normalize();
    const right = new THREE.Vector3().crossVectors(camera.up, back).normalize();
    const up = new THREE.Vector3().crossVectors(back, right);
    key.position.copy(controls.target)
      .addScaledVector(right, -1.4 * size).addScaledVector(up, 1.3 * size).addScaledVector(back, 1.2 * size);
    key.target.position.copy(controls.target);
    key.target.updateMatrixWorld();
  };
  const render = () => {
    placeLight();
    renderer.render(scene, camera);
  };
  const show = (name) => {
    const v = VIEWS[name] || VIEWS.home;
    const dist = fitDistance(box3, c, v.dir, v.up, FOV, camera.aspect);
    camera.up.fromArray(v.up);
    camera.position.copy(c).addScaledVector(new THREE.Vector3().fromArray(v.dir).normalize(), dist);
    controls.target.copy(c);
    camera.lookAt(c);
    controls.update();
    root.dataset.view = VIEWS[name] ? name : 'home';
    render();
  };
  controls.addEventListener('change', render);
  for (const name of ['reset', 'front', 'side', 'top']) {
    const b = document.getElementById('ps-' + name);
    if (b) b.addEventListener('click', () => show(name === 'reset' ? 'home' : name));
  }
  const albedo = document.getElementById('ps-albedo');
  albedo.disabled = !data.colors;
  albedo.addEventListener('change', () => {
    mesh.material.vertexColors = albedo.checked && !!data.colors;
    mesh.material.color.set(mesh.material.vertexColors ? 0xffffff : 0xc9c4bb);
    mesh.material.needsUpdate = true;
    render();
  });
  window.addEventListener('resize', () => {
    camera.aspect = box.clientWidth / box.clientHeight;
    camera.updateProjectionMatrix();
    renderer.setSize(box.clientWidth, box.clientHeight);
    render();
  });

  // `report.html#view=side` opens on that view (front, side, top; default: home).
  const wanted = (location.hash.match(/view=(\w+)/) || [])[1];
  show(wanted || 'home');
  requestAnimationFrame(() => {
    render();
    root.dataset.viewer = 'ready';
    root.dataset.triangles = String(data.indices ? mesh.geometry.index.count / 3 : 0);
  });
}

try {
  start();
} catch (err) {
  root.dataset.viewer = 'failed';
  box.textContent = '3-D view unavailable: ' + err.message;
  console.error('photostereo viewer: ' + err.message);
}
