LD.view3d = function () { throw new Error("todo"); };
