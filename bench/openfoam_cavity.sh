#!/usr/bin/env bash
# Makes real OpenFOAM cases with Debian's OpenFOAM (scripts/install-deps --bench): the
# lid-driven cavity (blockMesh, 20×20×6 hexahedra, 0.1 × 0.1 × 0.03 m) run by icoFoam for 10
# steps written in binary, and the same cavity turned into its polyhedral dual
# (polyDualMesh, feature angle 60) and run the same way; and both again at 80×80×24 cells run
# for 2 steps (cavity_large, dual_large). Each case folder gets a CASE.foam.
#   bench/openfoam_cavity.sh OUTDIR   (makes OUTDIR/cavity, dual, cavity_large, dual_large)
set -euo pipefail
out=${1:?usage: openfoam_cavity.sh OUTDIR}
export WM_PROJECT_DIR=/usr/share/openfoam FOAM_ETC=/usr/share/openfoam/etc
header() { echo "FoamFile { version 2.0; format ascii; class $1; object $2; }"; }
make_case() {
  local dir=$1 cells=${2:-20 20 6} end=${3:-0.05}
  rm -rf "$dir"
  mkdir -p "$dir/system" "$dir/constant" "$dir/0"
  { header dictionary blockMeshDict
    echo 'convertToMeters 0.1; vertices ( (0 0 0) (1 0 0) (1 1 0) (0 1 0) (0 0 0.3) (1 0 0.3) (1 1 0.3) (0 1 0.3) );'
    echo "blocks ( hex (0 1 2 3 4 5 6 7) ($cells) simpleGrading (1 1 1) ); edges ();"
    echo 'boundary ( movingWall { type wall; faces ((3 7 6 2)); } fixedWalls { type wall; faces ((0 4 7 3) (2 6 5 1) (1 5 4 0) (0 3 2 1) (4 5 6 7)); } ); mergePatchPairs ();'
  } > "$dir/system/blockMeshDict"
  { header dictionary controlDict
    echo "application icoFoam; startFrom startTime; startTime 0; stopAt endTime; endTime $end; deltaT 0.005;"
    echo 'writeControl timeStep; writeInterval 1; purgeWrite 0; writeFormat binary; writePrecision 6; writeCompression off;'
    echo 'timeFormat general; timePrecision 6; runTimeModifiable true;'
  } > "$dir/system/controlDict"
  { header dictionary fvSchemes
    echo 'ddtSchemes { default Euler; } gradSchemes { default Gauss linear; } divSchemes { default none; div(phi,U) Gauss linear; }'
    echo 'laplacianSchemes { default Gauss linear corrected; } interpolationSchemes { default linear; } snGradSchemes { default corrected; }'
  } > "$dir/system/fvSchemes"
  { header dictionary fvSolution
    echo 'solvers { p { solver PCG; preconditioner DIC; tolerance 1e-06; relTol 0.05; } pFinal { $p; relTol 0; }'
    echo '  U { solver smoothSolver; smoother symGaussSeidel; tolerance 1e-05; relTol 0; } }'
    echo 'PISO { nCorrectors 2; nNonOrthogonalCorrectors 0; pRefCell 0; pRefValue 0; }'
  } > "$dir/system/fvSolution"
  { header dictionary transportProperties; echo 'nu 0.01;'; } > "$dir/constant/transportProperties"
  { header volVectorField U; echo 'dimensions [0 1 -1 0 0 0 0]; internalField uniform (0 0 0);'
    echo 'boundaryField { movingWall { type fixedValue; value uniform (1 0 0); } fixedWalls { type noSlip; } }'; } > "$dir/0/U"
  { header volScalarField p; echo 'dimensions [0 2 -2 0 0 0 0]; internalField uniform 0;'
    echo 'boundaryField { movingWall { type zeroGradient; } fixedWalls { type zeroGradient; } }'; } > "$dir/0/p"
  (cd "$dir" && blockMesh > log.blockMesh 2>&1)
}
make_case "$out/cavity"
make_case "$out/dual"
make_case "$out/cavity_large" "80 80 24" 0.01
make_case "$out/dual_large" "80 80 24" 0.01
for c in dual dual_large; do
  (cd "$out/$c" && polyDualMesh 60 -overwrite > log.polyDualMesh 2>&1)
done
for c in cavity dual cavity_large dual_large; do
  (cd "$out/$c" && icoFoam > log.icoFoam 2>&1 && touch "$c.foam")
done
