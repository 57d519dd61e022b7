// The 3D view: one or two meshes (escape | cut-off side by side) in the box of the region,
// scaled so the box always fills the view (moving or zooming the region moves the set, as in
// QHD), orbited with the mouse, lit by one light fixed to the camera plus ambient light.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

export const kBackground = 0x1d2127;
const kBoxRadius = Math.sqrt(3);  // of the sphere around the box [-1, 1]^3 the view frames

// QHD's illumination models.
function makeMaterial(shading, vertexColors) {
  const common = { color: vertexColors ? 0xffffff : 0xd8d2c4, vertexColors, side: THREE.DoubleSide };
  if (shading === 'simple') return new THREE.MeshLambertMaterial({ ...common, flatShading: true });
  if (shading === 'lambert') return new THREE.MeshLambertMaterial(common);
  return new THREE.MeshPhongMaterial({ ...common, specular: 0x555555, shininess: 32 });
}

class Slot {
  constructor(background) {
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(background);
    this.object = new THREE.Group();  // rotated about X, Y, Z
    this.holder = new THREE.Group();  // the box of the region onto [-1, 1]
    this.object.add(this.holder);
    this.scene.add(this.object);
    this.ambient = new THREE.AmbientLight(0xffffff, 0.25);
    this.light = new THREE.DirectionalLight(0xffffff, 2.5);
    this.scene.add(this.ambient, this.light, this.light.target);
    this.mesh = null;
    this.box = null;
  }

  setBounds(bounds) {
    const min = new THREE.Vector3(...bounds.min);
    const max = new THREE.Vector3(...bounds.max);
    const size = max.clone().sub(min);
    const center = min.clone().add(max).multiplyScalar(0.5);
    const scale = 2 / Math.max(size.x, size.y, size.z);
    this.holder.scale.setScalar(scale);
    this.holder.position.copy(center).multiplyScalar(-scale);
    if (this.box) {
      this.holder.remove(this.box);
      this.box.geometry.dispose();
    }
    const edges = new THREE.EdgesGeometry(new THREE.BoxGeometry(size.x, size.y, size.z));
    this.box = new THREE.LineSegments(edges, new THREE.LineBasicMaterial({ color: 0x59606b }));
    this.box.position.copy(center);
    this.holder.add(this.box);
  }

  setGeometry(geometry, shading) {
    this.clear();
    this.mesh = new THREE.Mesh(geometry, makeMaterial(shading, geometry.hasAttribute('color')));
    this.holder.add(this.mesh);
  }

  setShading(shading) {
    if (!this.mesh) return;
    this.mesh.material.dispose();
    this.mesh.material = makeMaterial(shading, this.mesh.geometry.hasAttribute('color'));
  }

  clear() {
    if (!this.mesh) return;
    this.holder.remove(this.mesh);
    this.mesh.geometry.dispose();
    this.mesh.material.dispose();
    this.mesh = null;
  }
}

export class Viewer {
  constructor(canvas) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.camera = new THREE.PerspectiveCamera(30, 1, 0.1, 100);
    this.camera.position.set(0, 0, 6.2);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.enableZoom = false;  // the wheel zooms the region instead
    this.controls.enablePan = false;   // the arrows move the region instead
    this.controls.addEventListener('change', () => this.render());
    this.slots = [new Slot(kBackground), new Slot(kBackground)];
    this.sideBySide = false;
    this.shading = 'phong';
    this.lightView = new THREE.Vector3(-1, 1, 2);  // towards the light, view space
    this.loader = new GLTFLoader();
    new ResizeObserver(() => this.resize()).observe(canvas);
    this.resize();
  }

  resize() {
    const w = this.canvas.clientWidth, h = this.canvas.clientHeight;
    if (w === 0 || h === 0) return;
    this.renderer.setSize(w, h, false);
    this.render();
  }

  // Parses GLB bytes into the geometry of slot `index` (0: the main view or escape, 1: cut-off).
  async setMesh(index, glb, bounds) {
    const gltf = await this.loader.parseAsync(glb, '');
    let geometry = null;
    gltf.scene.traverse((o) => { if (o.isMesh && !geometry) geometry = o.geometry; });
    if (!geometry) throw new Error('the GLB holds no mesh');
    const slot = this.slots[index];
    slot.setBounds(bounds);
    slot.setGeometry(geometry, this.shading);
    this.render();
  }

  clearMesh(index) {
    this.slots[index].clear();
    this.render();
  }

  setBounds(bounds) {
    for (const s of this.slots) s.setBounds(bounds);
    this.render();
  }

  setSideBySide(on) {
    this.sideBySide = on;
    this.render();
  }

  setShading(shading) {
    this.shading = shading;
    for (const s of this.slots) s.setShading(shading);
    this.render();
  }

  // position: towards the light in view space (x right, y up, z towards the viewer).
  setLights({ position, intensity, ambient }) {
    this.lightView.set(...position);
    for (const s of this.slots) {
      s.light.intensity = intensity;
      s.ambient.intensity = ambient;
    }
    this.render();
  }

  // Degrees about X, then Y, then Z.
  setRotation(degrees) {
    const r = degrees.map((d) => THREE.MathUtils.degToRad(d));
    for (const s of this.slots) s.object.rotation.set(r[0], r[1], r[2], 'XYZ');
    this.render();
  }

  render() {
    const size = this.renderer.getSize(new THREE.Vector2());  // CSS pixels, as setViewport takes
    const w = size.x, h = size.y;
    if (w === 0 || h === 0) return;
    const views = this.sideBySide ? [[0, 0, Math.floor(w / 2), h], [Math.floor(w / 2), 0, w - Math.floor(w / 2), h]]
                                  : [[0, 0, w, h]];
    this.renderer.setScissorTest(true);
    views.forEach(([x, y, vw, vh], i) => {
      const slot = this.slots[i];
      // The light stays where it is relative to the camera while the object is orbited.
      slot.light.position.copy(this.lightView).normalize().multiplyScalar(10)
        .applyQuaternion(this.camera.quaternion);
      this.camera.aspect = vw / vh;
      this.camera.updateProjectionMatrix();
      // Far enough for the sphere around the box to fit both ways, also in a narrow half.
      const vertical = THREE.MathUtils.degToRad(this.camera.fov) / 2;
      const horizontal = Math.atan(Math.tan(vertical) * this.camera.aspect);
      this.camera.position.setLength(kBoxRadius / Math.sin(Math.min(vertical, horizontal)));
      this.renderer.setViewport(x, y, vw, vh);
      this.renderer.setScissor(x, y, vw, vh);
      this.renderer.render(slot.scene, this.camera);
    });
    this.renderer.setScissorTest(false);
  }

  // The view as a PNG blob.
  png() {
    this.render();
    return new Promise((resolve) => this.canvas.toBlob(resolve, 'image/png'));
  }
}
