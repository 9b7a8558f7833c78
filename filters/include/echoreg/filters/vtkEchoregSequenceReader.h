/**
 * @class   vtkEchoregSequenceReader
 * @brief   Reads a PLUS sequence file of A-lines (or a tracker-only capture) into an image.
 *
 * Reads a PLUS sequence (MetaImage .mha/.mhd with .raw/.zraw, NRRD .nrrd; raw, zlib or gzip
 * data) with echoreg::core::readSequence and presents it to the pipeline. The format is the PLUS
 * toolkit's (Lasso et al. 2014, "PLUS: open-source toolkit for ultrasound-guided intervention
 * systems"); A-lines are frames of N x 1 samples.
 *
 * Output (port 0): vtkImageData with dimensions (samples, frames, 1): x is the sample index, y the
 * frame; spacing (1, 1, 1), origin 0. The reader honours the update extent along y: a downstream
 * filter that streams the capture in blocks of frames (vtkEchoregPeakFilter's FramesPerBlock)
 * gets only the frames of its block copied, with their absolute frame indices as the extent. The
 * point scalars "ALines" keep the file's element type (VTK_UNSIGNED_CHAR, VTK_SIGNED_CHAR,
 * VTK_SHORT or VTK_FLOAT). A tracker-only capture (DimSize = 0 0 F) gives an image without points:
 * extent (0, -1, 0, F-1, 0, 0), so GetDimensions() reads (0, F, 1), no scalars, and the field data
 * below still present. Frames of more than one row (2D images, or a holder of several transducers)
 * are refused with echoreg::core::requireSingleALineFrames's sentence.
 *
 * Field data of the output (see echoreg::filters::SequenceFieldData): "Timestamp" (NaN where a
 * frame has none); per transform N: "N" (16 components, row-major), "N_Valid" (1 = status OK) and
 * "N_Status" (verbatim); "SamplingFrequencyHz", "DelayS", "SpeedOfSoundMps" (single tuples) and
 * "Transducer" when the file states them.
 *
 * The file is read once, in RequestInformation, and cached; it is read again only when the file
 * name changes, Modified() is called, or the file's modification time or size changes. The plain
 * struct of the last successful read is available from GetSequence().
 *
 * Errors (missing file, a directory, malformed content): vtkErrorMacro with the message of
 * echoreg::core::FileError, which names the file, the request fails (Update() leaves an empty
 * output) and GetLastError() returns the message; it is cleared by the next successful read.
 *
 * Poses used as rigid transforms: for each name of RigidPoseTransforms the capture holds, the rule
 * of echoreg::core::enforceRigidPoses is applied once after the read (poses within tolerance are
 * re-orthonormalised, others refused as an error naming the frame); GetRigidPoseReports() tells
 * what it did. Names the capture does not hold are left to the consumer (which lists the names
 * it has).
 *
 * Defaults: no file name (an error on update), no rigid-pose transforms.
 */
#pragma once

#include "echoreg/core/rigid_pose.hpp"
#include "echoreg/core/sequence.hpp"

#include <vtkImageAlgorithm.h>
#include <vtkSmartPointer.h>
#include <vtkTimeStamp.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

class vtkFieldData;

class vtkEchoregSequenceReader : public vtkImageAlgorithm {
 public:
  static vtkEchoregSequenceReader* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregSequenceReader, vtkImageAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /**
   * Path of the sequence file (.mha, .mhd, .nrrd). Default: empty.
   */
  void SetFileName(const std::string& fileName);
  const std::string& GetFileName() const { return this->FileName; }
  ///@}

  ///@{
  /**
   * Transforms whose valid poses must be rigid (e.g. {"ProbeToTracker", "FemurToTracker"});
   * empty names are ignored. Default: none.
   */
  void SetRigidPoseTransforms(const std::vector<std::string>& names);
  const std::vector<std::string>& GetRigidPoseTransforms() const {
    return this->RigidPoseTransforms;
  }
  ///@}

  /**
   * Per transform of RigidPoseTransforms the capture holds, what the rule did on the last read.
   */
  const std::vector<std::pair<std::string, echoreg::core::RigidPoseReport>>& GetRigidPoseReports()
      const {
    return this->RigidPoseReports;
  }

  /**
   * The sequence of the last successful read (empty before the first one).
   */
  const echoreg::core::Sequence& GetSequence() const { return this->Sequence; }

  /**
   * Message of the last failure ("PATH: problem"), empty after a success.
   */
  const std::string& GetLastError() const { return this->LastError; }

  /**
   * Number of times RequestData ran (pixels copied to the output; once per block when streamed).
   */
  int GetExecutionCount() const { return this->ExecutionCount; }

  /**
   * Number of times the file was actually read (the cache missed).
   */
  int GetReadCount() const { return this->ReadCount; }

 protected:
  vtkEchoregSequenceReader();
  ~vtkEchoregSequenceReader() override;

  int RequestInformation(vtkInformation* request, vtkInformationVector** inputVector,
                         vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregSequenceReader(const vtkEchoregSequenceReader&) = delete;
  void operator=(const vtkEchoregSequenceReader&) = delete;

  /// Reads the file unless the cache is current; false (with LastError set) on failure.
  bool ReadIfNeeded();
  /// Records and reports a failure.
  void Fail(const std::string& message);

  std::string FileName;
  std::vector<std::string> RigidPoseTransforms;
  std::vector<std::pair<std::string, echoreg::core::RigidPoseReport>> RigidPoseReports;
  echoreg::core::Sequence Sequence;
  std::string LastError;
  int ExecutionCount = 0;
  int ReadCount = 0;

  // Cache key of Sequence: what was read, when, and the file's state then.
  bool CacheValid = false;
  std::string CachedFileName;
  std::filesystem::file_time_type CachedFileTime{};
  std::uintmax_t CachedFileSize = 0;
  vtkTimeStamp CacheTime;
  // The field data of Sequence, built once per read and shared by every output (a streamed
  // capture would otherwise rebuild every frame's poses for each block).
  vtkSmartPointer<vtkFieldData> FieldData;
  vtkTimeStamp FieldDataTime;
};
