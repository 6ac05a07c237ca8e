// The page's palette, as sRGB bytes. ARM_COLOR is what the browser test looks for on the canvas, so the arm's
// material keeps most of its pixels near it (see scene.js, ShadedMaterial).
export const ARM_COLOR = [0, 168, 160];          // first arm: links of idle agents, of RMPflow, and the base
export const SECOND_ARM_COLOR = [150, 156, 166]; // second arm (side by side), drawn translucent
export const OPTION_COLORS = {
  'target': [40, 100, 240],
  'collision': [224, 48, 40],
  'target-then-collision': [255, 140, 20],
};
export const OBSTACLE_COLOR = [150, 128, 104];
export const SELECTED_COLOR = [255, 208, 0];
export const TARGET_COLOR = [40, 190, 80];
export const EE_COLORS = [[200, 40, 170], [120, 120, 130]];
export const WITNESS_COLORS = [[230, 170, 0], [140, 140, 140]];
export const BACKGROUND = [233, 237, 241];

// css colour of an [r, g, b] byte triple.
export function css([r, g, b], alpha = 1) {
  return alpha === 1 ? `rgb(${r}, ${g}, ${b})` : `rgba(${r}, ${g}, ${b}, ${alpha})`;
}
