// Materials whose lit faces stay close to their nominal colour: half of the colour is emitted, half is lit by the
// camera's head light, so a face turned towards the viewer shows the nominal sRGB colour and a grazing one about
// 3/4 of it. The arm stays recognisable by colour (the browser test counts its pixels) and still reads as 3D.
import * as THREE from 'three';

const EMITTED = 0.55;

export function linearColor([r, g, b]) {
  return new THREE.Color().setRGB(r / 255, g / 255, b / 255, THREE.SRGBColorSpace);
}

export function shadedMaterial(rgb, { opacity = 1 } = {}) {
  const c = linearColor(rgb);
  const m = new THREE.MeshLambertMaterial({
    color: c.clone().multiplyScalar(1 - EMITTED),
    emissive: c.clone().multiplyScalar(EMITTED),
  });
  if (opacity < 1) {
    m.transparent = true;
    m.opacity = opacity;
    m.depthWrite = false;
  }
  return m;
}

// the head light's intensity that makes a face turned to the camera show the full colour (Lambert: albedo/π).
export const HEAD_LIGHT_INTENSITY = Math.PI;
