// The parts of three.js the report's 3-D view uses (crates/study/src/report/view3d.js), bundled by
// vendor.sh into one classic script that defines the global `THREE_VIEW`.
export { WebGLRenderer, Scene, PerspectiveCamera, BufferGeometry, Float32BufferAttribute, Points, PointsMaterial, LineSegments, LineBasicMaterial, LineDashedMaterial, Mesh, MeshBasicMaterial, MeshLambertMaterial, AmbientLight, DirectionalLight, SphereGeometry, Color, Vector3, Group, CanvasTexture, Matrix4 } from 'three';
export { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
