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

function start() {
  const data = JSON.parse(document.getElementById('ps-mesh').textContent);
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(box.clientWidth, box.clientHeight);
  box.appendChild(renderer.domElement);

  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x1b1e24);
  const mesh = buildMesh(data);
  scene.add(mesh);

  const c = new THREE.Vector3().fromArray(data.center);
  const camera = new THREE.PerspectiveCamera(30, box.clientWidth / box.clientHeight, data.radius * 0.01, data.radius * 20);
  const dist = data.radius / Math.sin((30 / 2) * Math.PI / 180) * 1.05;
  const home = () => {
    camera.position.set(c.x + 0.42 * dist, c.y - 0.5 * dist, c.z + 0.76 * dist);
    camera.up.set(0, 1, 0);
    camera.lookAt(c);
  };
  home();
  scene.add(camera);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x30343c, 0.45));
  const head = new THREE.DirectionalLight(0xffffff, 2.4);
  head.position.set(-0.7, 0.6, 0.45);
  camera.add(head);
  camera.add(head.target);
  head.target.position.set(0, 0, -1);

  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(c);
  controls.update();
  const render = () => renderer.render(scene, camera);
  controls.addEventListener('change', render);

  document.getElementById('ps-reset').addEventListener('click', () => {
    home();
    controls.target.copy(c);
    controls.update();
    render();
  });
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

  render();
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
