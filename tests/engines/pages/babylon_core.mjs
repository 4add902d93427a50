// "@babylonjs/core" for the Babylon.js page (babylon.html's import map): the symbols the page and
// its snippet use, re-exported from their own modules with the registrations they need. The
// package's index.js loads ~3300 modules into every tab, which takes longer than a test may.
import "@babylonjs/core/Engines/Extensions/engine.cubeTexture.js";
import "@babylonjs/core/Engines/Extensions/engine.rawTexture.js";
import "@babylonjs/core/Engines/Extensions/engine.renderTarget.js";
import "@babylonjs/core/Engines/Extensions/engine.renderTargetCube.js";
import "@babylonjs/core/Engines/Extensions/engine.renderTargetTexture.js";
import "@babylonjs/core/Engines/Extensions/engine.prefilteredCubeTexture.js";
import "@babylonjs/core/Engines/Extensions/engine.readTexture.js";
import "@babylonjs/core/Materials/Textures/baseTexture.polynomial.js";
import "@babylonjs/core/Materials/Textures/Loaders/envTextureLoader.js";
import "@babylonjs/core/Loading/loadingScreen.js";
export { Engine } from "@babylonjs/core/Engines/engine.js";
export { Constants } from "@babylonjs/core/Engines/constants.js";
export { Scene } from "@babylonjs/core/scene.js";
export { TargetCamera } from "@babylonjs/core/Cameras/targetCamera.js";
export { Vector3 } from "@babylonjs/core/Maths/math.vector.js";
export { Color3, Color4 } from "@babylonjs/core/Maths/math.color.js";
export { CreateSphere } from "@babylonjs/core/Meshes/Builders/sphereBuilder.js";
export { PBRMaterial } from "@babylonjs/core/Materials/PBR/pbrMaterial.js";
export { ShaderMaterial } from "@babylonjs/core/Materials/shaderMaterial.js";
export { RenderTargetTexture } from "@babylonjs/core/Materials/Textures/renderTargetTexture.js";
export { CubeTexture } from "@babylonjs/core/Materials/Textures/cubeTexture.js";
export { AppendSceneAsync } from "@babylonjs/core/Loading/sceneLoader.js";
