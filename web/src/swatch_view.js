// The scan's real-time 3D view: the seamless tile (the scan's glTF export,
// read by three.js's GLTFLoader) on a draped sheet at its real size, lit
// per pixel from its normal map by a point light the user drags around or
// lets orbit, with a ruler beside it. The model and the light turn
// independently: dragging turns whichever "Drag turns" names, the sliders
// and arrow keys do the same for people without a mouse.
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { h } from './dom.js';

const SHEET_MIN_M = 0.05; // the sheet is at least this wide, whatever the tile
const SHEET_SEGMENTS = 96;

// The glTF export's material and the tile's size in metres (its quad).
export async function materialFromGlb(buffer) {
  const gltf = await new GLTFLoader().parseAsync(buffer, '');
  let mesh = null;
  gltf.scene.traverse((object) => {
    if (!mesh && object.isMesh) mesh = object;
  });
  if (!mesh) throw new Error('the glTF export has no mesh');
  mesh.geometry.computeBoundingBox();
  const size = new THREE.Vector3();
  mesh.geometry.boundingBox.getSize(size);
  const extents = [size.x, size.y, size.z].sort((a, b) => b - a);
  return { material: mesh.material, tileWidth: extents[0], tileHeight: extents[1] };
}

// A sheet hanging over a rounded edge: flat on top, folding down in front,
// with a soft ripple across, so the light grazes the weave at every angle.
function drapedSheet(width, depth, tileWidth, tileHeight) {
  const geometry = new THREE.PlaneGeometry(width, depth, SHEET_SEGMENTS, SHEET_SEGMENTS);
  const position = geometry.attributes.position;
  const uv = geometry.attributes.uv;
  const radius = depth * 0.18;
  for (let i = 0; i < position.count; i++) {
    const x = position.getX(i);
    const y = position.getY(i); // from -depth/2 (front) to depth/2 (back)
    // UVs in tiles: one tile per tileWidth × tileHeight metres.
    uv.setXY(i, (x + width / 2) / tileWidth, (y + depth / 2) / tileHeight);
    const front = -depth * 0.1; // where the sheet starts to fall over the edge
    let py = y;
    let pz = 0;
    if (y < front) {
      const along = front - y; // length of sheet past the edge
      const angle = Math.min(along / radius, Math.PI / 2);
      py = front - radius * Math.sin(angle);
      pz = -radius * (1 - Math.cos(angle)) - Math.max(0, along - (radius * Math.PI) / 2);
    }
    const ripple = 0.004 * Math.sin((x / width) * Math.PI * 3) * Math.max(0, (front - y) / depth);
    position.setXYZ(i, x, py + ripple, pz);
  }
  geometry.computeVertexNormals();
  return geometry;
}

// A ruler with millimetre ticks and centimetre numbers, as a texture on a
// thin strip: lying in front of the sheet, turning with it.
function ruler(lengthM) {
  const centimetres = Math.max(1, Math.floor(lengthM * 100));
  const canvas = document.createElement('canvas');
  const pxPerMm = 8;
  canvas.width = centimetres * 10 * pxPerMm + 40;
  canvas.height = 96;
  const g = canvas.getContext('2d');
  g.fillStyle = '#f4efe2';
  g.fillRect(0, 0, canvas.width, canvas.height);
  g.fillStyle = '#222';
  g.font = 'bold 28px sans-serif';
  g.textAlign = 'center';
  for (let mm = 0; mm <= centimetres * 10; mm++) {
    const x = 20 + mm * pxPerMm;
    const tall = mm % 10 === 0 ? 40 : mm % 5 === 0 ? 26 : 14;
    g.fillRect(x - 1, 0, 2, tall);
    if (mm % 10 === 0) g.fillText(String(mm / 10), x, 76);
  }
  g.textAlign = 'right';
  g.font = '22px sans-serif';
  g.fillText('cm', canvas.width - 6, 90);
  const texture = new THREE.CanvasTexture(canvas);
  texture.colorSpace = THREE.SRGBColorSpace;
  texture.anisotropy = 4;
  const width = (canvas.width / (pxPerMm * 10)) * 0.01;
  const strip = new THREE.Mesh(
    new THREE.BoxGeometry(width, 0.024, 0.0015),
    new THREE.MeshStandardMaterial({ map: texture, roughness: 0.6 }),
  );
  return strip;
}

export class SwatchView {
  constructor(container) {
    this.container = container;
    this.canvas = h('canvas', {
      class: 'swatch-canvas',
      tabindex: 0,
      role: 'img',
      'aria-label': 'The swatch in 3D at real size. Drag or use the arrow keys to turn it, the wheel to come closer.',
    });
    this.lightAzimuth = 35;
    this.lightElevation = 40;
    this.modelYaw = -20;
    this.modelPitch = 25;
    this.orbit = true;
    this.dragTarget = 'model';
    this.frames = 0;
    this.controls = this.buildControls();
    container.append(this.canvas, this.controls);

    this.renderer = new THREE.WebGLRenderer({
      canvas: this.canvas,
      antialias: true,
      preserveDrawingBuffer: true, // so a screenshot or a test can read the picture
    });
    this.renderer.outputColorSpace = THREE.SRGBColorSpace;
    this.renderer.toneMapping = THREE.NeutralToneMapping; // keeps the yarn's colour
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x2a2d33);
    this.camera = new THREE.PerspectiveCamera(35, 1, 0.005, 10);
    this.model = new THREE.Group();
    this.scene.add(this.model);
    this.scene.add(new THREE.HemisphereLight(0xdfe8ff, 0x3a3026, 0.6));
    // No falloff (decay 0): the swatch is as bright at any size; the
    // direction changes across the sheet as a lamp's would.
    this.light = new THREE.PointLight(0xffffff, 2.6, 0, 0);
    this.lightMarker = new THREE.Mesh(
      new THREE.SphereGeometry(0.004, 16, 12),
      new THREE.MeshBasicMaterial({ color: 0xfff6d8 }),
    );
    this.scene.add(this.light, this.lightMarker);
    this.bindPointer();
    this.resize = () => this.fit();
    window.addEventListener('resize', this.resize);
    this.fit();
    this.running = true;
    this.last = performance.now();
    this.tick = this.tick.bind(this);
    requestAnimationFrame(this.tick);
  }

  buildControls() {
    const slider = (id, label, value, min, max, onInput) => {
      const input = h('input', { id, type: 'range', min, max, step: 1, value });
      input.addEventListener('input', () => onInput(Number(input.value)));
      return [h('label', { for: id }, label), input];
    };
    const [azLabel, az] = slider('sv-light-azimuth', 'Light direction (°)', this.lightAzimuth, 0, 359, (v) => {
      this.lightAzimuth = v;
      this.setOrbit(false);
    });
    const [elLabel, el] = slider('sv-light-elevation', 'Light height (°)', this.lightElevation, 5, 90, (v) => {
      this.lightElevation = v;
    });
    this.azimuthInput = az;
    this.elevationInput = el;
    this.orbitInput = h('input', { id: 'sv-orbit', type: 'checkbox', checked: this.orbit });
    this.orbitInput.addEventListener('change', () => this.setOrbit(this.orbitInput.checked));
    const radio = (value, label) => {
      const input = h('input', {
        type: 'radio',
        name: 'sv-drag',
        id: `sv-drag-${value}`,
        value,
        checked: this.dragTarget === value,
      });
      input.addEventListener('change', () => (this.dragTarget = value));
      return [input, h('label', { for: `sv-drag-${value}` }, label)];
    };
    return h(
      'div',
      { class: 'view-controls' },
      h('div', {}, this.orbitInput, h('label', { for: 'sv-orbit' }, 'Orbit the light')),
      h('fieldset', {}, h('legend', {}, 'Drag turns'), radio('model', 'the swatch'), radio('light', 'the light')),
      h('div', { class: 'slider' }, azLabel, az),
      h('div', { class: 'slider' }, elLabel, el),
    );
  }

  setOrbit(on) {
    this.orbit = on;
    this.orbitInput.checked = on;
  }

  bindPointer() {
    let dragging = null;
    this.canvas.addEventListener('pointerdown', (event) => {
      dragging = { x: event.clientX, y: event.clientY, light: this.dragTarget === 'light' || event.shiftKey };
      this.canvas.setPointerCapture(event.pointerId);
    });
    this.canvas.addEventListener('pointermove', (event) => {
      if (!dragging) return;
      const dx = event.clientX - dragging.x;
      const dy = event.clientY - dragging.y;
      dragging.x = event.clientX;
      dragging.y = event.clientY;
      this.turn(dragging.light, dx * 0.5, dy * 0.5);
    });
    const end = () => (dragging = null);
    // The wheel brings the camera closer, down to a few stitches.
    this.canvas.addEventListener(
      'wheel',
      (event) => {
        event.preventDefault();
        this.zoom = Math.min(1.5, Math.max(0.08, (this.zoom ?? 1) * Math.exp(event.deltaY * 0.001)));
        this.fit();
      },
      { passive: false },
    );
    this.canvas.addEventListener('pointerup', end);
    this.canvas.addEventListener('pointercancel', end);
    this.canvas.addEventListener('keydown', (event) => {
      const step = { ArrowLeft: [-5, 0], ArrowRight: [5, 0], ArrowUp: [0, -5], ArrowDown: [0, 5] }[event.key];
      if (!step) return;
      event.preventDefault();
      this.turn(this.dragTarget === 'light' || event.shiftKey, step[0], step[1]);
    });
  }

  turn(light, dx, dy) {
    if (light) {
      this.setOrbit(false);
      this.lightAzimuth = (((this.lightAzimuth + dx) % 360) + 360) % 360;
      this.lightElevation = Math.min(90, Math.max(5, this.lightElevation - dy));
    } else {
      this.modelYaw += dx;
      this.modelPitch = Math.min(85, Math.max(-10, this.modelPitch + dy));
    }
  }

  // The material and tile size from the glTF export; the sheet at least
  // SHEET_MIN_M wide and a whole number of tiles.
  show({ material, tileWidth, tileHeight }) {
    this.model.clear();
    for (const key of ['map', 'normalMap', 'aoMap', 'roughnessMap', 'sheenColorMap']) {
      const texture = material[key];
      if (!texture) continue;
      texture.wrapS = texture.wrapT = THREE.RepeatWrapping;
      texture.repeat.set(1, 1); // the sheet's UVs count tiles already
      texture.offset.set(0, 0);
      texture.anisotropy = this.renderer.capabilities.getMaxAnisotropy();
      texture.needsUpdate = true;
    }
    material.side = THREE.DoubleSide;
    const across = Math.max(1, Math.ceil(SHEET_MIN_M / tileWidth));
    const width = across * tileWidth;
    const depth = Math.max(1, Math.round((width * 0.8) / tileHeight)) * tileHeight;
    const sheet = new THREE.Mesh(drapedSheet(width, depth, tileWidth, tileHeight), material);
    sheet.rotation.x = -Math.PI / 2; // lying in the x-z plane, falling toward the viewer
    this.model.add(sheet);
    const scale = ruler(Math.min(width, 0.3));
    scale.rotation.x = -Math.PI / 2;
    scale.position.set(0, 0.0015, -depth / 2 - 0.016); // just behind the sheet's back edge
    this.model.add(scale);
    this.size = Math.max(width, depth);
    this.fit();
  }

  fit() {
    const width = this.canvas.clientWidth || 640;
    const height = this.canvas.clientHeight || 420;
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    const distance = (this.size ?? 0.15) * 1.9 * (this.zoom ?? 1);
    this.camera.position.set(0, distance * 0.35, distance);
    // Aim between the sheet and the ruler behind it, so both stay in view.
    this.camera.lookAt(0, -0.1 * (this.size ?? 0.15), -0.2 * (this.size ?? 0.15));
    this.camera.near = distance / 100;
    this.camera.far = distance * 10;
    this.camera.updateProjectionMatrix();
  }

  tick(now) {
    if (!this.running) return;
    const seconds = Math.min(0.1, (now - this.last) / 1000);
    this.last = now;
    if (this.orbit) {
      this.lightAzimuth = (this.lightAzimuth + seconds * 30) % 360;
      this.azimuthInput.value = Math.round(this.lightAzimuth);
    }
    this.elevationInput.value = Math.round(this.lightElevation);
    const r = (this.size ?? 0.15) * 0.9;
    const az = THREE.MathUtils.degToRad(this.lightAzimuth);
    const el = THREE.MathUtils.degToRad(this.lightElevation);
    this.light.position.set(r * Math.cos(el) * Math.cos(az), r * Math.sin(el), r * Math.cos(el) * Math.sin(az));
    this.lightMarker.position.copy(this.light.position);
    this.model.rotation.set(THREE.MathUtils.degToRad(this.modelPitch), THREE.MathUtils.degToRad(this.modelYaw), 0, 'XYZ');
    this.renderer.render(this.scene, this.camera);
    this.frames++;
    this.canvas.dataset.frames = this.frames;
    requestAnimationFrame(this.tick);
  }

  dispose() {
    this.running = false;
    window.removeEventListener('resize', this.resize);
    this.model.traverse((object) => {
      object.geometry?.dispose();
      const material = object.material;
      if (material) {
        for (const value of Object.values(material)) if (value?.isTexture) value.dispose();
        material.dispose();
      }
    });
    this.renderer.dispose();
  }
}
