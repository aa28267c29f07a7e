// terrascape web viewer: the terrain glb embedded in this page, drawn with three.js.
// Loaded as a module from a blob URL by the page's bootstrap (works from file:// and http).
import * as THREE from 'three';
import { GLTFLoader } from 'GLTFLoader';
import { OrbitControls } from 'OrbitControls';

const config = JSON.parse(document.getElementById('terrain-config').textContent);
const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(window.innerWidth, window.innerHeight, false);
renderer.outputColorSpace = THREE.SRGBColorSpace;

const scene = new THREE.Scene();
scene.background = new THREE.Color(config.sky);
const camera = new THREE.PerspectiveCamera(45, window.innerWidth / window.innerHeight, 0.1, 1e7);
const controls = new OrbitControls(camera, canvas);
const render = () => renderer.render(scene, camera);
controls.addEventListener('change', render);
window.addEventListener('resize', () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight, false);
  render();
});

function frame(root) {
  const box = new THREE.Box3().setFromObject(root);
  const size = box.getSize(new THREE.Vector3());
  const centre = box.getCenter(new THREE.Vector3());
  const span = Math.max(size.x, size.z, 1e-6);
  const fit = span / 2 / Math.tan(THREE.MathUtils.degToRad(camera.fov / 2));
  controls.target.copy(centre);
  if (window.location.hash === '#top') {
    // straight down, north (−z) up: the whole map fills the view, as the baked texture does
    const depth = Math.max(size.z, size.x / camera.aspect) / 2 /
      Math.tan(THREE.MathUtils.degToRad(camera.fov / 2));
    camera.position.set(centre.x, box.max.y + depth * 1.02, centre.z + 1e-3 * span);
    camera.up.set(0, 0, -1);
  } else {
    // from the south-east, 35° above the horizon
    const d = fit * 1.15;
    const el = THREE.MathUtils.degToRad(35);
    camera.position.set(centre.x + d * Math.cos(el) * 0.5, centre.y + d * Math.sin(el),
      centre.z + d * Math.cos(el) * 0.87);
  }
  camera.near = span / 5000;
  camera.far = span * 50;
  camera.updateProjectionMatrix();
  controls.update();
}

const text = document.getElementById('terrain-glb').textContent.trim();
const bytes = Uint8Array.from(atob(text), (c) => c.charCodeAt(0));
// Light for the objects (trees, rocks, buildings) the glb may carry; the terrain is unlit.
scene.add(new THREE.HemisphereLight(0xc8dcff, 0x50463a, 1.4));
const sun = new THREE.DirectionalLight(0xfff0dc, 2.2);
sun.position.set(0.64, 0.57, 0.64);  // the baked texture's sun: azimuth 135°, 35° up
scene.add(sun);

new GLTFLoader().parse(bytes.buffer, '', (gltf) => {
  const root = gltf.scene;
  root.traverse((o) => {
    // The texture already holds the sun and the shadows: draw it unlit, as baked.
    if (o.isMesh && o.material && o.material.map) {
      o.material = new THREE.MeshBasicMaterial({ map: o.material.map });
    }
  });
  scene.add(root);
  frame(root);
  render();
  document.title = 'terrain loaded';
  document.body.dataset.loaded = '1';
}, (error) => {
  document.title = 'terrain failed: ' + error;
});
